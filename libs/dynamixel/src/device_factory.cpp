#include "dynamixel/device_factory.h"

#include "dynamixel/darwin_boards.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/protocol1_servo.h"

namespace doppel::dynamixel {

BuiltDevice make_protocol1_device(std::string_view model, uint8_t id, uint32_t baud_bps, uint8_t return_delay_raw) {
  const ModelSpec& spec = model_spec(model);
  const uint8_t baud_raw = p1_baud_register(baud_bps, spec);
  switch (spec.kind) {
    case DeviceKind::kImu:
      return built<SimulatedImu>(std::make_unique<FumanoidImu>(id, baud_raw, return_delay_raw));
    case DeviceKind::kFootBoard:
      return built<SimulatedFootBoard>(std::make_unique<FumanoidFootBoard>(id, baud_raw, return_delay_raw));
    case DeviceKind::kCm730:
      return built<SimulatedController>(std::make_unique<Cm730>(id, baud_raw, return_delay_raw));
    case DeviceKind::kDarwinFsr:
      return built<SimulatedFootBoard>(std::make_unique<DarwinFsr>(id, baud_raw, return_delay_raw));
    case DeviceKind::kServo:
      break;
  }
  return built<SimulatedServo>(std::make_unique<Protocol1Servo>(spec, id, baud_raw, return_delay_raw));
}

}  // namespace doppel::dynamixel
