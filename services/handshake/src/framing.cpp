#include "handshake/framing.h"

#include <algorithm>

namespace doppel::handshake {

std::string encode_frame(std::string_view payload) {
  const auto n = static_cast<uint32_t>(payload.size());
  std::string out;
  out.reserve(kLengthBytes + payload.size());
  for (std::size_t i = 0; i < kLengthBytes; ++i) {
    out.push_back(static_cast<char>((n >> (8 * i)) & 0xFFu));
  }
  out.append(payload);
  return out;
}

std::size_t FrameDecoder::feed(const uint8_t* data, std::size_t n) {
  std::size_t used = 0;
  if (state_ != State::kNeedMore) {
    return 0;
  }
  while (prefix_used_ < kLengthBytes && used < n) {
    prefix_[prefix_used_++] = data[used++];
    if (prefix_used_ == kLengthBytes) {
      length_ = static_cast<uint32_t>(prefix_[0]) | static_cast<uint32_t>(prefix_[1]) << 8 |
                static_cast<uint32_t>(prefix_[2]) << 16 | static_cast<uint32_t>(prefix_[3]) << 24;
      if (length_ > max_) {
        state_ = State::kTooLarge;
        return used;
      }
      payload_.reserve(length_);
    }
  }
  if (prefix_used_ < kLengthBytes) {
    return used;
  }
  const std::size_t take = std::min<std::size_t>(n - used, length_ - payload_.size());
  payload_.append(reinterpret_cast<const char*>(data + used), take);
  used += take;
  if (payload_.size() == length_) {
    state_ = State::kFrame;
  }
  return used;
}

void FrameDecoder::next() noexcept {
  if (state_ != State::kFrame) {
    return;
  }
  if (payload_.capacity() > (64u << 10)) {
    payload_ = std::string();  // one large frame does not keep its buffer for the connection's life
  }
  payload_.clear();
  prefix_used_ = 0;
  length_ = 0;
  state_ = State::kNeedMore;
}

}  // namespace doppel::handshake
