#pragma once
// The DARwIn-OP's own boards on its Protocol 1.0 bus: the CM-730 sub-controller (ID 200) and the two
// FSR foot boards (IDs 111 right, 112 left). Their control tables are those of the DARwIn-OP
// framework's CM730.h / FSR.h and the e-Manual (docs/devices.md names every source); the framework
// talks to them with the MX-28's instruction set, BULK READ included, so both are Protocol1Device
// models. Values are latched at every apply(): the boards sample far faster than the 8 ms cycle.

#include <cstdint>

#include "base/supply.h"
#include "dynamixel/device_io.h"
#include "dynamixel/protocol1_device.h"

namespace doppel::dynamixel {

// The CM-730: 3-axis gyro and accelerometer as 10-bit values centred at 512, supply voltage, MODE
// and START buttons, LEDs, and the switch of the servos' supply (Dynamixel Power).
class Cm730 final : public Protocol1Device, public SimulatedController {
 public:
  // 10 bit, 512 at zero. Accelerometer: -4..4 g (e-Manual, platform/op/references; Webots' model
  // alike). Gyro: -1600..1600 deg/s, as Webots' DARwIn-OP model maps it (Darwin-op.proto, Gyro
  // lookupTable +-27.925 rad/s over 0..1024); the e-Manual's text says -500..500 deg/s. Webots'
  // figure is taken because the framework's own gyro balance, tuned on the robot, is unstable on
  // this body at any scale above 0.45 of the e-Manual's (docs/devices.md, DARwIn-OP "Corrections
  // for the framework's walk"; open: a measurement of a CM-730).
  static constexpr double kGyroDegSPerCount = 1600.0 / 512.0;
  static constexpr double kAccelGPerCount = 4.0 / 512.0;
  static constexpr double kStandardGravityMS2 = 9.80665;
  static constexpr double kVoltageUnitV = 0.1;

  // Throws std::invalid_argument for out-of-range register values. Setup only.
  Cm730(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);
  // S is the accelerometer's frame (on the robot: x right, y forward, z up): ACC X/Y/Z = a_WS_S
  // (x, y, z). The gyro's axes are turned 90 deg about z (x back, y right, z up): Gyro X = -w_WS_S.y,
  // Gyro Y = w_WS_S.x, Gyro Z = w_WS_S.z (docs/devices.md, CM-730 axes). Saturate at 0 and 1023.
  // rt-safe.
  void apply(const ImuFeedback& feedback) noexcept override;
  // Present Voltage = supply_v in 0.1 V. rt-safe.
  void apply(const PowerFeedback& feedback) noexcept override;
  // Button = bits 0 (MODE) and 1 (START) of `input.pressed`. rt-safe.
  void apply(const ButtonInput& input) noexcept override;
  // Dynamixel Power (24) is 1: the manual's "turn on the power of all DYNAMIXEL connected to
  // CM-730". The board only reports it; the gateway switches the other devices of its bus with it
  // (BusDevices::set_powered, docs/devices.md).
  bool dxl_power_on() const noexcept { return register_raw(cm730::kDxlPower) != 0; }
};

// An FSR foot board: four load cells (FSR1..4, 1 mN) and the centre of pressure (FSR_Central_X/Y,
// 0..254 across the board, 255 without load).
class DarwinFsr final : public Protocol1Device, public SimulatedFootBoard {
 public:
  static constexpr double kForceUnitN = 0.001;    // e-Manual: 1/1000 N per unit
  static constexpr double kMinimumLoadN = 0.493;  // e-Manual: smallest measurable load; less reads 0
  static constexpr uint8_t kNoContact = 255;      // FSR_Central_X/Y without load

  // Throws std::invalid_argument for out-of-range register values. Setup only.
  DarwinFsr(uint8_t id, uint8_t baud_raw, uint8_t return_delay_raw);
  // feedback.force_n[i] -> FSR(i + 1); the cells sit at the corners of the board's sensing
  // rectangle in FootFeedback order (front-left, front-right, back-left, back-right), so
  // FSR_Central_X = 254 x (FSR2 + FSR4) / sum (0 = left edge) and FSR_Central_Y = 254 x (FSR1 + FSR2)
  // / sum (0 = back edge). rt-safe.
  void apply(const FootFeedback& feedback) noexcept override;
  // Present Voltage (42) in 0.1 V; the board is fed from the servo bus. rt-safe.
  void set_supply_voltage(double volts) noexcept;

 protected:
  // RESET and a power cycle clear the RAM; the supply is still there, so Present Voltage reads it again.
  void after_factory_reset() noexcept override { set_supply_voltage(supply_v_); }

 private:
  double supply_v_ = 0.0;
};

}  // namespace doppel::dynamixel
