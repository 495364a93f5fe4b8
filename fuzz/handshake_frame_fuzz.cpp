// Arbitrary bytes from a handshake client through the frame decoder (fed in slices of the size byte
// 0 picks), each whole frame parsed as a ClientMessage and its add_robot checked, as the server
// does. Must never crash; frames stay within the maximum, a refusal names an add_robot field, an
// accepted request keeps every limit the checks promise.
#include <cmath>
#include <cstdint>
#include <string>

#include "fuzz_check.h"
#include "handshake/framing.h"
#include "handshake/request.h"

namespace hs = doppel::handshake;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) {
    return 0;
  }
  const std::size_t slice = 1 + data[0] % 64;
  constexpr uint32_t kMax = 4096;
  hs::FrameDecoder decoder(kMax);
  std::size_t offset = 1;
  while (offset < size) {
    const std::size_t n = std::min(slice, size - offset);
    const std::size_t used = decoder.feed(data + offset, n);
    FUZZ_CHECK(used <= n);
    offset += used;
    if (decoder.state() == hs::FrameDecoder::State::kTooLarge) {
      FUZZ_CHECK(decoder.announced_length() > kMax);
      break;  // the server closes here
    }
    if (decoder.state() != hs::FrameDecoder::State::kFrame) {
      FUZZ_CHECK(used == n);
      continue;
    }
    const std::string_view frame = decoder.frame();
    FUZZ_CHECK(frame.size() == decoder.announced_length() && frame.size() <= kMax);
    hs::wire::ClientMessage request;
    if (!request.ParseFromArray(frame.data(), static_cast<int>(frame.size()))) {
      break;  // the server closes here
    }
    if (request.has_add_robot()) {
      const auto checked = hs::check_add_robot(request.add_robot());
      if (const auto* refusal = std::get_if<doppel::contract::Refusal>(&checked)) {
        FUZZ_CHECK(refusal->field.rfind("add_robot.", 0) == 0 && !refusal->message.empty());
      } else {
        const auto& r = std::get<doppel::contract::RobotRequest>(checked);
        FUZZ_CHECK(r.robot.empty() != r.description.empty());
        FUZZ_CHECK(!r.team || *r.team <= 1);
        FUZZ_CHECK(!r.x_m || std::fabs(*r.x_m) <= 100.0);
        for (const auto& c : r.cameras) {
          FUZZ_CHECK(!c.width_px || (*c.width_px >= 2 && *c.width_px <= 8192));
          FUZZ_CHECK(!c.fps || (*c.fps > 0.0 && *c.fps <= 1000.0));
        }
        FUZZ_CHECK(!r.world_model || (r.world_model->dropout >= 0.0 && r.world_model->dropout < 1.0));
      }
    }
    decoder.next();
  }
  return 0;
}
