#pragma once
// Doppel's FUmanoid sensor boards (thesis §4.2.1.3/4.2.1.4): an IMU and a foot board with four
// load cells, as Protocol 1.0 devices on the servo bus. They are modern MCU boards with a
// servo-like register header, so generic drivers can ping them, and they understand the full P1
// instruction set including BULK READ. Values are latched at a fixed sample period from the
// simulation feed; reads return the last latched sample. Register maps: docs/devices.md.

#include <cstdint>

#include "dynamixel/device_io.h"
#include "dynamixel/protocol1_device.h"

namespace doppel::dynamixel {

// What both boards share: sampling on a fixed grid of simulation time.
class FumanoidBoard : public Protocol1Device {
 public:
  // Sample Period register in ns.
  int64_t sample_period_ns() const noexcept;
  // Latched samples so far (the Sample Counter register wraps at 65536).
  uint64_t samples() const noexcept { return samples_; }

 protected:
  FumanoidBoard(const ModelSpec& spec, DeviceKind kind, uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);
  // True when a sample taken at `t_ns` is due: the first one, one at or after the next multiple
  // of the sample period, or one from a simulation that went back in time. Advances the grid.
  bool sample_due(int64_t t_ns) noexcept;
  void after_factory_reset() noexcept override;

 private:
  bool has_sample_ = false;
  int64_t last_sample_ns_ = 0;
  int64_t next_sample_ns_ = 0;
  uint64_t samples_ = 0;
};

// The FUmanoid IMU board: pitch, roll, yaw, 3-axis gyro, 3-axis accelerometer, latched every Sample
// Period (default 20 ms = 50 Hz, like the thesis' Kalman-filter IMU).
class FumanoidImu final : public FumanoidBoard, public SimulatedImu {
 public:
  static constexpr double kAngleUnitRad = 1e-4;    // Pitch/Roll/Yaw: 0.1 mrad
  static constexpr double kGyroUnitRadS = 1e-3;    // Gyro X/Y/Z: 1 mrad/s
  static constexpr double kAccelUnitMS2 = 1e-2;    // Accel X/Y/Z: 0.01 m/s^2

  // Throws std::invalid_argument for out-of-range register values. Setup only.
  FumanoidImu(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);
  // Latches `feedback` into the registers when a sample is due (feedback.sim_time_ns). Values
  // outside int16 saturate. rt-safe.
  void apply(const ImuFeedback& feedback) noexcept override;
};

// The FUmanoid foot board: four load cells and their sum, latched every Sample Period (default 10 ms).
class FumanoidFootBoard final : public FumanoidBoard, public SimulatedFootBoard {
 public:
  static constexpr double kForceUnitN = 0.01;  // Force registers: 0.01 N, 0..655.35 N

  // Throws std::invalid_argument for out-of-range register values. Setup only.
  FumanoidFootBoard(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);
  // Latches `feedback` when a sample is due. Negative (pulling) forces read 0; values saturate at
  // 65535. rt-safe.
  void apply(const FootFeedback& feedback) noexcept override;
};

}  // namespace doppel::dynamixel
