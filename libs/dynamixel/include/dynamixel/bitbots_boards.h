#pragma once
// The Bit-Bots sensor boards on a Protocol 2.0 bus (reference §8.1-8.4): the IMU DXL module
// (ID 241), the BitFoot foot-pressure boards (IDs 101, 102) and the CORE board their driver pings
// at start. They run ROBOTIS' Dynamixel2Arduino slave, not servo firmware, and Doppel keeps its
// quirks: only unicast PING, READ and WRITE are executed (everything else, and every broadcast,
// is dropped without a status), a packet with a bad CRC is dropped, a READ returns exactly the
// requested length with 0 for unregistered bytes and for items not entirely inside the range, a
// WRITE updates only items entirely inside it, and there is no Status Return Level or Return
// Delay Time. Register maps: docs/devices.md (Protocol 2.0 part).

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "dynamixel/device.h"
#include "dynamixel/device_io.h"
#include "dynamixel/protocol2_models.h"

namespace doppel::dynamixel {

// Control-table addresses of the Bit-Bots boards (reference §8.2-8.4).
namespace bitbots {
inline constexpr uint16_t kModelNumber = 0;
inline constexpr uint16_t kFirmwareVersion = 6;
inline constexpr uint16_t kId = 7;
inline constexpr uint16_t kBaud = 8;
inline constexpr uint16_t kProtocolVersion = 9;
inline constexpr uint16_t kLed0 = 10;  // red, green, blue at 10, 11, 12 (IMU, CORE)
inline constexpr uint16_t kLed1 = 14;
inline constexpr uint16_t kLed2 = 18;
// IMU: float32 each.
inline constexpr uint16_t kGyroX = 36;  // rad/s
inline constexpr uint16_t kGyroY = 40;
inline constexpr uint16_t kGyroZ = 44;
inline constexpr uint16_t kAccelX = 48;  // m/s^2, specific force
inline constexpr uint16_t kAccelY = 52;
inline constexpr uint16_t kAccelZ = 56;
inline constexpr uint16_t kQuaternionX = 60;  // orientation x, y, z, w (ROS order)
inline constexpr uint16_t kQuaternionY = 64;
inline constexpr uint16_t kQuaternionZ = 68;
inline constexpr uint16_t kQuaternionW = 72;
inline constexpr uint16_t kButton0 = 76;  // u8, 1 = pressed (76, 77, 78)
inline constexpr uint16_t kGyroOdr = 100;
inline constexpr uint16_t kAccelOdr = 101;
inline constexpr uint16_t kGyroRange = 102;
inline constexpr uint16_t kAccelRange = 103;
inline constexpr uint16_t kDoAdaptiveGain = 108;
inline constexpr uint16_t kDoBiasEstimation = 109;
inline constexpr uint16_t kAccelGain = 110;  // float32
inline constexpr uint16_t kBiasAlpha = 114;  // float32
// BitFoot: int32 raw ADC counts (or float32, see BitFootCalibration).
inline constexpr uint16_t kSensor0 = 36;  // front left
inline constexpr uint16_t kSensor1 = 40;  // front right
inline constexpr uint16_t kSensor2 = 44;  // back left
inline constexpr uint16_t kSensor3 = 48;  // back right
// CORE: u8 switches, u16 raw 10-bit ADC values.
inline constexpr uint16_t kCoreLed = 22;
inline constexpr uint16_t kPower = 23;
inline constexpr uint16_t kVext = 28;
inline constexpr uint16_t kVcc = 30;
inline constexpr uint16_t kVdxl = 32;
inline constexpr uint16_t kCurrent = 34;
inline constexpr uint16_t kPowerSense = 36;
inline constexpr uint16_t kVbat0 = 38;  // VBAT 0..5 at 38, 40, ..., 48
}  // namespace bitbots

// What every Dynamixel2Arduino-slave board shares.
class BitbotsBoard : public Device {
 public:
  static constexpr std::size_t kTableBytes = 256;

  // One registered control item.
  struct Item {
    uint16_t address = 0;   // first byte
    uint8_t size = 1;       // bytes
    bool writable = false;  // WRITE updates it (model number, firmware and sensor values do not)
  };

  Protocol protocol() const noexcept override { return Protocol::kV2; }
  uint8_t id() const noexcept override { return table_[bitbots::kId]; }
  uint32_t baud_bps() const noexcept override;
  uint32_t return_delay_us() const noexcept override { return 0; }  // answers at once (no RDT item)
  std::string_view model_name() const noexcept override { return spec_.name; }
  uint16_t model_number() const noexcept override { return spec_.model_number; }
  // rt-safe.
  void handle(const InstructionPacket& packet, Response& response) noexcept override;

  // The stored bytes 0..255 (unregistered bytes 0).
  std::span<const uint8_t> table() const noexcept { return table_; }
  // Restarts caused by a write to the baud item (the board resets before it can answer).
  uint64_t restarts() const noexcept { return restarts_; }

 protected:
  // Throws std::invalid_argument for an ID above 252 or a baud index the board does not have.
  BitbotsBoard(const P2ModelSpec& spec, std::span<const Item> items, uint8_t id, uint8_t baud_raw);

  void store_u8(uint16_t address, uint8_t value) noexcept { table_[address] = value; }
  void store_u16(uint16_t address, uint16_t value) noexcept;
  void store_u32(uint16_t address, uint32_t value) noexcept;
  void store_f32(uint16_t address, float value) noexcept;
  float load_f32(uint16_t address) const noexcept;

 private:
  const P2ModelSpec& spec_;
  std::span<const Item> items_;
  std::array<uint8_t, kTableBytes> table_{};
  std::array<uint8_t, kMaxInstructionParams> scratch_{};
  uint64_t restarts_ = 0;
};

// The Bit-Bots IMU: gyro, accelerometer and orientation quaternion of the current (BMI088) firmware,
// latched at every apply().
class BitbotsImu final : public BitbotsBoard, public SimulatedImu {
 public:
  // Throws std::invalid_argument for an ID above 252 or a bad baud index. Setup only.
  BitbotsImu(uint8_t id, uint8_t baud_raw);
  // Gyro = w_WS_S, accel = a_WS_S, quaternion of roll/pitch/yaw (ZYX) as x, y, z, w. rt-safe.
  void apply(const ImuFeedback& feedback) noexcept override;
};

// How a BitFoot reports force: raw = zero_counts + force / newton_per_count (the inverse of the
// driver's pressure_converter); int32 (firmware) or float32 (docs, driver since 2024-07).
struct BitFootCalibration {
  double zero_counts = 1.0e7;       // count at no load (stored robot calibrations: order 1e7)
  double newton_per_count = 3.0e-6; // scale (stored robot calibrations: order 3e-6)
  bool float32 = false;             // items as IEEE-754 float instead of int32 counts
};

// The Bit-Bots BitFoot: four load cells (front left, front right, back left, back right), latched at every apply().
class BitFoot final : public BitbotsBoard, public SimulatedFootBoard {
 public:
  // Throws std::invalid_argument for an ID above 252, a bad baud index or a zero scale. Setup only.
  BitFoot(uint8_t id, uint8_t baud_raw, const BitFootCalibration& calibration = {});
  // Counts saturate at the int32 range. rt-safe.
  void apply(const FootFeedback& feedback) noexcept override;
  const BitFootCalibration& calibration() const noexcept { return calibration_; }

 private:
  BitFootCalibration calibration_;
};

// The Bit-Bots CORE board: power switch, supply voltages and current as the raw ADC values its driver decodes.
// Its current sensor sits in the servo supply it switches (all four buses of the robot), so it
// measures what the servos together draw from the battery.
class BitbotsCore final : public BitbotsBoard, public SimulatedPowerBoard {
 public:
  static constexpr double kAdcVoltsPerCount = 3.3 / 1024.0 * 6.0;  // driver: V = raw * 3.3 / 1024 * 6
  static constexpr double kVccV = 5.0;                              // logic supply (assumption)

  // Throws std::invalid_argument for an ID above 252 or a bad baud index. Setup only.
  BitbotsCore(uint8_t id, uint8_t baud_raw);
  // Supply `supply_v` (V) and servo current `current_a` (A) -> VEXT, VCC, VDXL (0 while Power is 0),
  // Current (0 A while Power is 0), power sense and the six battery taps. rt-safe.
  void apply(double supply_v, double current_a) noexcept;
  // The same from a measurement of the simulation. rt-safe.
  void apply(const PowerFeedback& feedback) noexcept override { apply(feedback.supply_v, feedback.servo_current_a); }
  bool power_on() const noexcept { return table()[bitbots::kPower] != 0; }
};

}  // namespace doppel::dynamixel
