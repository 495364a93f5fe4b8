#pragma once
// The handshake's framing (libs/proto/handshake.proto): a 4-byte little-endian length, then that many
// bytes of one serialized message. The decoder keeps at most one frame of at most the maximum size,
// so a peer that announces a huge length or sends garbage costs a bounded buffer, never more.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace doppel::handshake {

inline constexpr uint32_t kDefaultMaxFrameBytes = 1u << 20;  // an inline robot file is ~20 KB
inline constexpr std::size_t kLengthBytes = 4;

// The length prefix and `payload` as one buffer.
std::string encode_frame(std::string_view payload);

class FrameDecoder {
 public:
  enum class State {
    kNeedMore,  // feed more bytes
    kFrame,     // frame() is one whole message; call next() before feeding more
    kTooLarge,  // the announced length exceeds the maximum: the stream cannot be followed further
  };

  explicit FrameDecoder(uint32_t max_frame_bytes = kDefaultMaxFrameBytes) : max_(max_frame_bytes) {}

  // Takes bytes until a frame is complete (or the length is refused) and returns how many it took;
  // the caller feeds the rest after next().
  std::size_t feed(const uint8_t* data, std::size_t n);
  State state() const noexcept { return state_; }
  std::string_view frame() const noexcept { return state_ == State::kFrame ? std::string_view(payload_) : std::string_view(); }
  uint32_t announced_length() const noexcept { return length_; }  // valid once the prefix is complete
  // Some bytes of a frame have arrived but not all of it.
  bool mid_frame() const noexcept { return state_ == State::kNeedMore && (prefix_used_ > 0 || !payload_.empty()); }
  void next() noexcept;  // after kFrame: start on the next frame

 private:
  uint32_t max_;
  uint8_t prefix_[kLengthBytes] = {};
  std::size_t prefix_used_ = 0;
  uint32_t length_ = 0;
  std::string payload_;
  State state_ = State::kNeedMore;
};

}  // namespace doppel::handshake
