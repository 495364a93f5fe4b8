#pragma once
// Every sensor at two levels (libs/proto/sensor_levels.proto, docs/multilevel.md): what a servo's, IMU's
// or foot board's registers hold, decoded to SI units as the device's manual defines them, beside the
// simulation's true value of the same quantity at the same step. body/ is where physics readouts
// become device feedback; this is the way back, so that a test can see what the encoding lost.
//
// The registers belong to the bus thread. It copies each sensor's control table together with the
// feedback it applied (the simulation's truth, as the simulation thread published it) into a
// fixed-size BusLevelsSample (copy_table: no allocation, rt-safe) at a rate in simulation time; a
// non-real-time thread decodes the bytes and fills the message (append_bus_levels). The decoders
// read the bytes only, as a driver does, never the device objects or the simulation's floats.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "dynamixel/bitbots_boards.h"
#include "dynamixel/device.h"
#include "dynamixel/device_io.h"
#include "dynamixel/models.h"
#include "proto/sensor_levels.pb.h"

namespace doppel::body {

inline constexpr std::size_t kLevelsMaxServos = 64;  // dynamixel::BusDevices::kMaxDevices
inline constexpr std::size_t kLevelsMaxBoards = 8;
// Bytes of each control table copied: every register decoded lies below (X Present Temperature: 146).
inline constexpr std::size_t kLevelsTableBytes = 160;

// How a device's bytes are decoded (one per register map).
enum class LevelsCodec : uint8_t {
  kP1Servo,      // AX/RX/MX, Protocol 1.0 control table
  kP2Servo,      // X series and MX(2.0), Protocol 2.0 control table
  kCm730,        // DARwIn-OP sub-controller: 10-bit gyro and accelerometer
  kFumanoidImu,  // Doppel's FUmanoid IMU board (docs/devices.md)
  kBitbotsImu,   // Bit-Bots IMU: float32 gyro, accelerometer, quaternion
  kOpenCr,       // OP3 OpenCR: MPU-9250 counts, angles in 0.1 deg
  kDarwinFsr,    // DARwIn-OP FSR foot board: 1 mN
  kFumanoidFoot, // Doppel's FUmanoid foot board: 0.01 N
  kBitFoot,      // Bit-Bots BitFoot: load-cell counts with a calibration
};

// One device's table as the bus thread copied it.
struct DeviceTable {
  std::array<uint8_t, kLevelsTableBytes> bytes{};
  bool powered = true;  // false: its supply is switched off
};

// What one bus' sensors held at one step (bus thread -> levels thread, in a Snapshot).
struct BusLevelsSample {
  uint64_t sequence = 0;    // +1 per sample; 0 = none yet
  int64_t sim_time_ns = 0;  // of the feedback the registers were set from and of the truth
  std::array<DeviceTable, kLevelsMaxServos> servo_tables{};
  std::array<dynamixel::ServoFeedback, kLevelsMaxServos> servo_truth{};
  std::array<DeviceTable, kLevelsMaxBoards> imu_tables{};
  std::array<dynamixel::ImuFeedback, kLevelsMaxBoards> imu_truth{};
  std::array<DeviceTable, kLevelsMaxBoards> foot_tables{};
  std::array<dynamixel::FootFeedback, kLevelsMaxBoards> foot_truth{};
};

// What the decoder must know of one device (setup).
struct LevelsDevice {
  uint32_t bus = 0;
  uint8_t id = 0;
  std::string name;
  std::string model;
  LevelsCodec codec = LevelsCodec::kP1Servo;
  dynamixel::ServoSpec servo{};       // servos: position, speed units (model registry, from the e-Manual)
  double current_unit_a = 0.0;        // servos with a current register: A per unit; 0 = none
  double stall_torque_nm = 0.0;       // servos: what Torque Limit 100 % means at the rated voltage
  dynamixel::BitFootCalibration foot_calibration{};  // BitFoot: the calibration its driver applies
};

// Setup: how to decode `device` (model `model` of `firmware`, file name `name`). Throws
// std::invalid_argument naming the model when Doppel has no decoder for it.
LevelsDevice levels_device(uint32_t bus, uint8_t id, const std::string& name, const std::string& model,
                           dynamixel::Protocol firmware, const dynamixel::Device& device);

// Setup: the control table bytes of `device` (a view that stays valid while it lives). Throws
// std::invalid_argument for a device class whose table Doppel cannot see.
std::span<const uint8_t> device_table(const dynamixel::Device& device);

// Bus thread: copies `table` (its first kLevelsTableBytes) into `out`. rt-safe.
void copy_table(std::span<const uint8_t> table, bool powered, DeviceTable& out) noexcept;

// The decoders: bytes -> SI, each the inverse of the device's encoding as its manual states it.
void decode_servo(const LevelsDevice& device, const DeviceTable& table, levels::ServoDecoded& out);
void decode_imu(const LevelsDevice& device, const DeviceTable& table, levels::ImuDecoded& out);
// Force per cell, N, in the order front-left, front-right, back-left, back-right; raw as stored.
void decode_foot(const LevelsDevice& device, const DeviceTable& table, std::array<double, 4>& force_n,
                 std::array<int64_t, 4>& raw);

// The devices of one bus, by servo / IMU / foot-board index (the indices of BusLevelsSample).
struct BusLevelsLayout {
  std::vector<LevelsDevice> servos;
  std::vector<LevelsDevice> imus;
  std::vector<LevelsDevice> feet;
};

// Non-real-time: appends every device of `layout` from `sample` (decoded and truth) to `out`.
void append_bus_levels(const BusLevelsLayout& layout, const BusLevelsSample& sample, levels::SensorLevels& out);

}  // namespace doppel::body
