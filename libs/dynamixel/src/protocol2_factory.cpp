#include "dynamixel/protocol2_factory.h"

#include "dynamixel/bitbots_boards.h"
#include "dynamixel/opencr_board.h"
#include "dynamixel/protocol2_servo.h"

namespace doppel::dynamixel {

BuiltDevice make_protocol2_device(std::string_view model, uint8_t id, uint32_t baud_bps, uint8_t return_delay_raw) {
  const P2ModelSpec& spec = p2_model_spec(model);
  const uint8_t baud_raw = p2_baud_register(baud_bps, spec);
  switch (spec.kind) {
    case P2DeviceKind::kBitbotsImu:
      return built<SimulatedImu>(std::make_unique<BitbotsImu>(id, baud_raw));
    case P2DeviceKind::kBitFoot:
      return built<SimulatedFootBoard>(std::make_unique<BitFoot>(id, baud_raw));
    case P2DeviceKind::kBitbotsCore:
      return built<SimulatedPowerBoard>(std::make_unique<BitbotsCore>(id, baud_raw));
    case P2DeviceKind::kOpenCr:
      return built<SimulatedController>(std::make_unique<OpenCr>(id, baud_raw));
    case P2DeviceKind::kServo:
      break;
  }
  return built<SimulatedServo>(std::make_unique<Protocol2Servo>(spec, id, baud_raw, return_delay_raw));
}

}  // namespace doppel::dynamixel
