#pragma once
// What crosses between a device's control table and the simulated world, in SI units.
// Registers -> command (what the firmware asks of the motor), world -> feedback (what the sensors
// measure) -> registers. Plain values, so they can cross threads through snapshots.
// Conventions: angles in rad with 0 at the centre of the servo's range, positive = CCW seen from the
// horn (the direction in which the position register grows).

#include <array>
#include <cstdint>

#include "base/supply.h"

namespace doppel::dynamixel {

// PID gains in register units: output (PWM units of the controller's full scale) per position unit,
// per position unit x s, per position unit / s. Each servo model converts its own gain registers.
struct PidGains {
  double kp = 0.0;
  double ki = 0.0;
  double kd = 0.0;
};

// Register values that the servo firmware's motor controller acts on.
struct ServoCommand {
  bool torque_enabled = false;      // Torque Enable, and no shutdown active
  bool wheel_mode = false;          // endless turn (both angle limits 0): moving_speed is a signed output
  double goal_position_rad = 0.0;   // target angle, already clamped to [min_position_rad, max_position_rad]
  double moving_speed_rad_s = 0.0;  // joint: speed limit toward the goal (0 = no limit); wheel: signed target speed
  double torque_limit_ratio = 1.0;  // Torque Limit as a fraction of the maximum torque, 0..1
  double min_position_rad = 0.0;    // CW angle limit
  double max_position_rad = 0.0;    // CCW angle limit
  // Controller registers, raw as in the control table, for the motor controller of the physics issue.
  uint8_t cw_compliance_margin_raw = 0;   // AX/RX: dead band, position units
  uint8_t ccw_compliance_margin_raw = 0;  // AX/RX
  uint8_t cw_compliance_slope_raw = 0;    // AX/RX
  uint8_t ccw_compliance_slope_raw = 0;   // AX/RX
  uint16_t punch_raw = 0;                 // AX/RX/MX: minimum drive
  PidGains pid{};                         // MX and X series: position PID from the gain registers
  bool multi_turn = false;                // MX: both angle limits 4095; goal may span several turns
  bool torque_control = false;            // MX-64/106 Torque Ctrl Mode Enable, X current mode: follow goal_current_a
  double goal_current_a = 0.0;            // MX-64/106 Goal Torque, X Goal Current: motor current, + = CCW
  double current_limit_a = 0.0;           // X current-based position: |motor current| at most this (0 = none)
  bool pwm_control = false;               // X PWM mode: the duty is goal_pwm_ratio, no feedback
  double goal_pwm_ratio = 0.0;            // X Goal PWM as a fraction of full duty, + = CCW
  bool velocity_control = false;          // X velocity mode: PI on the speed error toward moving_speed_rad_s
  PidGains velocity_pi{};                 // X velocity mode: from Velocity P/I Gain (x_velocity_pi_gains)
  double goal_acceleration_rad_s2 = 0.0;  // MX Goal Acceleration (0 = no limit)
};

// What the world measures at a servo.
struct ServoFeedback {
  double position_rad = 0.0;     // joint angle
  double velocity_rad_s = 0.0;   // joint speed, + = CCW
  double torque_ratio = 0.0;     // load as a fraction of the maximum torque, + = CCW, -1..1
  double voltage_v = kDefaultSupplyVoltage_v;  // supply at the servo
  double temperature_c = 25.0;   // motor temperature
  double current_a = 0.0;        // motor current, + = CCW torque (Present Current of servos that sense it)
  double torque_nm = 0.0;        // output torque, + = CCW: no register shows it; the sensor levels' truth
  bool overload = false;         // the firmware's motor controller reports overload (ControllerOutput)
  int64_t sim_time_ns = 0;       // simulation time of the measurement (MX Realtime Tick)
};

// What an IMU measures, in the IMU's own frame S (x forward, y left, z up when mounted level).
struct ImuFeedback {
  double roll_rad = 0.0;                             // rotation about x
  double pitch_rad = 0.0;                            // rotation about y, + = nose down
  double yaw_rad = 0.0;                              // rotation about z
  std::array<double, 3> w_WS_S_rad_s{};              // angular velocity of S in world W, expressed in S
  std::array<double, 3> a_WS_S_m_s2{0.0, 0.0, 9.80665};  // specific force (proper acceleration) in S
  int64_t sim_time_ns = 0;                           // simulation time of the measurement
};

// What the four load cells of one foot measure (normal force, N), in board order.
struct FootFeedback {
  std::array<double, 4> force_n{};  // front-left, front-right, back-left, back-right
  int64_t sim_time_ns = 0;          // simulation time of the measurement
};

// What a power board measures on the servo supply rail it switches.
struct PowerFeedback {
  double supply_v = 14.8;        // supply voltage (battery or bench supply) before the servo switch
  double servo_current_a = 0.0;  // current drawn from it by the servos, >= 0 while they draw power
  int64_t sim_time_ns = 0;       // simulation time of the measurement
};

// The simulation's side of a device, whatever protocol and model it is: the gateway reads what
// the firmware asks of the motor and writes back what the world measured, through these alone.
// All calls rt-safe.
class SimulatedServo {
 public:
  // Registers -> what the motor controller should do (SI, conventions above).
  virtual ServoCommand command() const noexcept = 0;
  // Measured values -> Present registers, Moving, error conditions.
  virtual void apply(const ServoFeedback& feedback) noexcept = 0;

 protected:
  ~SimulatedServo() = default;
};

// The simulation's side of a sensor or power board: it takes what the world measured.
template <typename Feedback>
class SimulatedBoard {
 public:
  virtual void apply(const Feedback& feedback) noexcept = 0;

 protected:
  ~SimulatedBoard() = default;
};

// Which buttons of a board are held down: bit n is bit n of the board's Button register.
struct ButtonInput {
  uint8_t pressed = 0;  // bit mask, 1 = pressed
};

using SimulatedImu = SimulatedBoard<ImuFeedback>;
using SimulatedFootBoard = SimulatedBoard<FootFeedback>;
using SimulatedPowerBoard = SimulatedBoard<PowerFeedback>;
using SimulatedButtons = SimulatedBoard<ButtonInput>;

// A robot's sub-controller board (DARwIn-OP CM-730, OP3 OpenCR): one device that carries the IMU,
// measures the supply and has the robot's buttons, so it takes all three inputs.
class SimulatedController : public SimulatedImu, public SimulatedPowerBoard, public SimulatedButtons {
 public:
  using SimulatedImu::apply;
  using SimulatedPowerBoard::apply;
  using SimulatedButtons::apply;

 protected:
  ~SimulatedController() = default;
};

}  // namespace doppel::dynamixel
