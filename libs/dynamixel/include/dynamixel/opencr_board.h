#pragma once
// The ROBOTIS OpenCR as the OP3 uses it: a Protocol 2.0 slave at ID 200 running ROBOTIS' OP3
// firmware (ROBOTIS-GIT/OpenCR, arduino/opencr_arduino/opencr/libraries/OP3/examples/opencr_op3),
// whose control table the OP3 framework reads as robotis_device/devices/sensor/OPEN-CR.device
// (ROBOTIS-GIT/ROBOTIS-Framework). Doppel keeps the firmware's quirks: it executes PING, READ,
// WRITE, SYNC READ/WRITE and BULK READ/WRITE and drops everything else; it has no Status Return
// Level or Return Delay Time (answers at once, always); a READ returns raw bytes of the 51-byte
// table whatever their items; a WRITE is acknowledged before it runs and changes only the writable
// bytes inside it; a new ID takes effect at the next power-up. docs/devices.md has the table.

#include <array>
#include <cstdint>
#include <span>
#include <string_view>

#include "dynamixel/device.h"
#include "dynamixel/device_io.h"
#include "dynamixel/protocol2_models.h"

namespace doppel::dynamixel {

// Addresses of the OpenCR's OP3 control table (dxl_node_op3.h, OPEN-CR.device).
namespace opencr {
inline constexpr uint16_t kModelNumber = 0;
inline constexpr uint16_t kFirmwareVersion = 2;
inline constexpr uint16_t kId = 3;
inline constexpr uint16_t kBaudRate = 4;  // index into 9600 .. 4.5 Mbps as the X series; 4 = 2 Mbps
inline constexpr uint16_t kReturnDelayTime = 5;
inline constexpr uint16_t kStatusReturnLevel = 16;
inline constexpr uint16_t kRollOffset = 18;  // int16, 0.1 deg (firmware only, not in OPEN-CR.device)
inline constexpr uint16_t kPitchOffset = 20;
inline constexpr uint16_t kYawOffset = 22;
inline constexpr uint16_t kDxlPower = 24;
inline constexpr uint16_t kLed = 25;     // bits 0..2 = LED 1..3
inline constexpr uint16_t kLedRgb = 26;  // RGB555, red bits 0-4
inline constexpr uint16_t kBuzzer = 28;  // tone in Hz, 0 = off
inline constexpr uint16_t kButton = 30;  // bits 0..3 = mode, start, user, S4
inline constexpr uint16_t kVoltage = 31; // 0.1 V
inline constexpr uint16_t kGyroX = 32;   // int16, MPU-9250 at 2000 deg/s: 16.4 per deg/s
inline constexpr uint16_t kGyroY = 34;
inline constexpr uint16_t kGyroZ = 36;
inline constexpr uint16_t kAccX = 38;    // int16, MPU-9250 at 2 g: 16384 per g
inline constexpr uint16_t kAccY = 40;
inline constexpr uint16_t kAccZ = 42;
inline constexpr uint16_t kRoll = 44;    // int16, 0.1 deg
inline constexpr uint16_t kPitch = 46;
inline constexpr uint16_t kYaw = 48;
inline constexpr uint16_t kImuControl = 50;  // bits 0..2: take roll/pitch/yaw as offset; bit 3: gyro calibration
inline constexpr uint16_t kTableBytes = 51;  // sizeof(dxl_mem_op3_t)
}  // namespace opencr

class OpenCr final : public Device, public SimulatedController {
 public:
  static constexpr double kGyroCountsPerDegS = 32800.0 / 2000.0;  // open_cr_module GYRO_FACTOR
  static constexpr double kAccCountsPerG = 32768.0 / 2.0;         // open_cr_module ACCEL_FACTOR
  static constexpr double kStandardGravityMS2 = 9.80665;

  // Throws std::invalid_argument for an ID above 252 or a baud index outside 0..7. Setup only.
  OpenCr(uint8_t id, uint8_t baud_raw);

  Protocol protocol() const noexcept override { return Protocol::kV2; }
  // The ID it answers to: the ID register as it was at power-up.
  uint8_t id() const noexcept override { return active_id_; }
  uint32_t baud_bps() const noexcept override;
  uint32_t return_delay_us() const noexcept override { return 0; }
  std::string_view model_name() const noexcept override { return spec_.name; }
  uint16_t model_number() const noexcept override { return spec_.model_number; }
  // rt-safe.
  void handle(const InstructionPacket& packet, Response& response) noexcept override;

  // Gyro and accelerometer of the board frame S (raw MPU-9250 counts, saturating at int16), roll,
  // pitch and yaw in 0.1 deg minus the stored offsets; runs the IMU Control requests. rt-safe.
  void apply(const ImuFeedback& feedback) noexcept override;
  // Voltage as the firmware computes it: (supply + 0.5 V) x 10, truncated (dxl_hw_op3.cpp). rt-safe.
  void apply(const PowerFeedback& feedback) noexcept override;
  // Button = bits 0..3 of `input.pressed`. rt-safe.
  void apply(const ButtonInput& input) noexcept override;

  // The stored bytes 0..50.
  std::span<const uint8_t> table() const noexcept { return {table_.data(), opencr::kTableBytes}; }
  // Dynamixel Power (24) is 1 (the firmware switches the servos' supply with it).
  bool dxl_power_on() const noexcept { return table_[opencr::kDxlPower] == 1; }

 private:
  void store_i16(uint16_t address, int32_t value) noexcept;
  int16_t load_i16(uint16_t address) const noexcept;
  // processWrite of the firmware: every writable byte of [start, start + n) inside the table.
  void write_bytes(uint16_t start, const uint8_t* data, std::size_t n) noexcept;
  // Status for this board in position `position` of a SYNC/BULK READ list.
  void chain_reply(uint16_t position, uint16_t start, uint16_t length, Response& response) noexcept;

  const P2ModelSpec& spec_;
  std::array<uint8_t, 256> table_{};
  std::array<uint8_t, kMaxInstructionParams> scratch_{};
  uint8_t active_id_ = 0;
  std::array<double, 3> angle_deg_{};   // last roll, pitch, yaw
  std::array<double, 3> offset_deg_{};  // offsets the firmware subtracts
};

}  // namespace doppel::dynamixel
