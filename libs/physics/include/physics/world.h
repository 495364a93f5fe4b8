#pragma once
// The simulated world the gateway drives: one or more robots built from their Robot Description
// Files, a static field, a ball, on an exchangeable engine (Backend). Each step applies every
// servo's motor voltage through the DC-motor model, steps the engine by the fixed step, and updates
// what the bus devices read back: joint angle/speed/torque, motor temperature, IMU, load cells.
//
// The world knows servos only by their (bus index, ID) in the description; it never sees a control
// table or a packet: the drive loop (body/servo_drive.h) runs the firmware and hands the
// resulting voltage to set_motor(). Angles at this interface are the servo's: 0 at the centre of
// its range, + = CCW (the direction in which the position register grows).
//
// A robot starts in its description's initial pose, its feet on the floor, held by a "handler":
// the root body pinned and every joint locked, as a person holds a robot while it powers up. The
// hold ends when the first servo of that robot gets Torque Enable (HoldMode::kUntilTorque), at
// once (kReleased), or by release(). Same inputs on the same engine and build give a bit-identical
// trajectory: fixed step, no wall clock, fixed iteration order.
//
// Threads: construct on any thread; then one thread calls step() and the readouts. step(),
// set_motor() and the readouts are rt-safe: no allocation, no locks, no exceptions.
//
// Robots can be added and removed while the world runs (add_robot / remove_robot, on the stepping
// thread between two steps; docs/robots-at-run-time.md). Those two calls allocate and may take
// longer than a step (the step that carries them out may overrun); every other step stays
// allocation-free. The others do not notice: their indices, handles, bodies and joints stay; a
// removed robot leaves an empty slot (has_robot() false) that the next add_robot reuses.

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "base/supply.h"
#include "physics/backend.h"
#include "physics/dc_motor.h"
#include "physics/robot_model.h"
#include "physics/scene_view.h"

namespace doppel::physics {

enum class HoldMode : uint8_t {
  kUntilTorque,  // held until its driver has switched its servos on (default; WorldOptions::hold_hand_over_s)
  kReleased,     // free from the first step (a limp robot falls)
};

struct RobotPlacement {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // robot frame origin on the floor (z is ignored:
                                                         // the robot is lowered until it touches the floor)
  double yaw_rad = 0.0;                                  // heading, about z
  uint8_t team = 0;                                      // team marker colour: 0 cyan, 1 magenta
};

inline constexpr size_t kMaxExtraBalls = 7;

struct BallOptions {
  bool present = true;                                   // add a dynamic ball
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();  // centre; z is set to the radius
  double radius_m = 0.0335;                              // orange tennis ball (FieldSpec::ball_diameter_m / 2)
  double mass_kg = 0.057;
  MaterialSpec material{0.5, 0.6};
};

struct WorldOptions {
  double step_s = 0.001;           // fixed step
  double gravity_m_s2 = 9.80665;   // along -z
  double supply_voltage_v = kDefaultSupplyVoltage_v;  // supply of servos whose bus sets no
                                                     // supply_voltage_v; the others use their bus'
                                                     // (MotorModel::supply_voltage_v)
  double ambient_c = 25.0;         // start and ambient temperature of the motors
  HoldMode hold = HoldMode::kUntilTorque;
  double hold_torque_nm = 50.0;    // how hard the handler holds each joint
  // kUntilTorque: from the first Torque Enable the handler hands the robot over joint by joint
  // (a joint whose servo has torque follows its servo, the others stay held, the trunk stays
  // pinned) and lets go when every servo of the robot has torque or this long after the first,
  // as a driver that enables its servos one at a time (ROBOTIS' robotis_controller) needs.
  // 0 = let go at the first Torque Enable.
  double hold_hand_over_s = 1.0;
  double imu_accel_filter_s = 0.005;  // accelerometer low-pass time constant (a MEMS part's
                                      // anti-alias filter, about 30 Hz); 0 = raw finite difference
  int solver_iterations = 10;      // constraint solver sweeps per step (docs/physics.md: why 10)
  bool powered_gear_friction = false;  // gear friction also while a servo is powered (always when
                                       // it is not); off by default, docs/physics.md says why
  MaterialSpec ground{0.8, 0.0};   // carpet
  BallOptions ball;
  // More balls (a session's scene, e.g. for the world-model sensor's nearest-ball rule): ball 1, 2,
  // ... after `ball`, which stays "the ball" of every single-ball call. At most kMaxExtraBalls; an
  // entry's `present` is ignored. Extra ball i has object_id kBallObjectId + 1 + i (field.h).
  std::vector<BallOptions> extra_balls;
  // Static field objects, normally field_shapes() of field.h: every shape except carpet, lines and
  // rings becomes a static collision shape (goals, nets, poles: friction 0.5, restitution 0.5);
  // all are copied into the scene view.
  std::vector<VisualShape> field;
};

// Handles: indices into the world's flat lists, stable for the world's lifetime.
struct MotorHandle {
  uint32_t index = 0;
};
struct ImuHandle {
  uint32_t index = 0;
};
struct FootHandle {
  uint32_t index = 0;
};

// The readouts below are the world's own plain structs (physics knows no device); body/feedback.h
// turns them into what the devices measure, in one place.
struct MotorState {
  double position_rad = 0.0;      // servo angle, 0 = centre, + = CCW
  double velocity_rad_s = 0.0;    // + = CCW
  double torque_nm = 0.0;         // output torque of the motor, + = CCW
  double torque_ratio = 0.0;      // torque / maximum torque at the supply voltage (Present Load), -1..1
  double current_a = 0.0;         // motor (winding) current, torque / kt, + = CCW torque
  double supply_current_a = 0.0;  // what the servo's H-bridge draws from its supply: winding current x
                                  // motor voltage (R i + ke w) / supply voltage; < 0 while the motor
                                  // feeds energy back
  double temperature_c = 25.0;    // winding temperature
  double voltage_v = kDefaultSupplyVoltage_v;  // supply voltage at the servo
};

struct ImuState {
  double roll_rad = 0.0;                                 // rotation about x of the sensor frame S
  double pitch_rad = 0.0;                                // about y, + = nose down
  double yaw_rad = 0.0;                                  // about z
  std::array<double, 3> w_WS_S_rad_s{};                  // angular velocity of S, expressed in S
  std::array<double, 3> a_WS_S_m_s2{0.0, 0.0, 9.80665};  // specific force (what an accelerometer reads) in S
  int64_t sim_time_ns = 0;
};

struct FootState {
  std::array<double, 4> force_n{};  // FL, FR, BL, BR normal force along the foot's z, >= 0
  int64_t sim_time_ns = 0;
};

class World {
 public:
  // Builds the world. `robots` and `placements` pair up (placements may be shorter: the rest stand
  // in a row along y). Throws std::invalid_argument (more than 6 robots, bad options).
  World(std::unique_ptr<Backend> backend, std::vector<RobotModel> robots, std::vector<RobotPlacement> placements,
        WorldOptions options);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  // Adds a robot standing at `placement` (lowered onto the floor, in its initial pose, held as the
  // world's robots are at the start) into the first empty slot; returns its index. Between steps
  // on the stepping thread; allocates. Throws std::invalid_argument when kMaxRobotGroups robots are
  // in the world, and whatever the engine throws (then nothing of the robot is left).
  size_t add_robot(RobotModel robot, const RobotPlacement& placement);
  // Takes robot `robot` out: its bodies and joints leave the engine (nothing collides with them),
  // its motor, IMU and foot handles go dead (readouts keep their last values, set_motor ignores
  // them), its slot stays empty. Between steps; allocates nothing but may free. Throws
  // std::invalid_argument when there is no such robot.
  void remove_robot(size_t robot);
  // True when slot `robot` holds a robot. rt-safe.
  bool has_robot(size_t robot) const noexcept;

  // Look-ups (setup): nullopt when the robot has no such device in its figure.
  std::optional<MotorHandle> find_motor(size_t robot, uint32_t bus, uint8_t id) const noexcept;
  std::optional<ImuHandle> find_imu(size_t robot, uint32_t bus, uint8_t id) const noexcept;
  std::optional<FootHandle> find_foot(size_t robot, uint32_t bus, uint8_t id) const noexcept;

  // The firmware's output for one servo, used from the next step on. With HoldMode::kUntilTorque
  // the first enabled command of a robot releases it. rt-safe.
  void set_motor(MotorHandle motor, const MotorCommand& command) noexcept;

  // One fixed step. rt-safe.
  void step() noexcept;

  // Readouts of the last step. rt-safe.
  MotorState motor(MotorHandle motor) const noexcept;
  ImuState imu(ImuHandle imu) const noexcept;
  FootState foot(FootHandle foot) const noexcept;
  double time_s() const noexcept { return static_cast<double>(steps_) * options_.step_s; }
  int64_t time_ns() const noexcept { return steps_ * step_ns_; }
  uint64_t steps() const noexcept { return steps_; }

  // The handler: hold() pins the robot where it is and locks its joints; release() lets go. rt-safe.
  void hold(size_t robot) noexcept;
  void release(size_t robot) noexcept;
  bool held(size_t robot) const noexcept;
  // Puts a held robot's robot frame at X_WR (joints at their held positions), e.g. to tilt it.
  // Setup code (allocates); the robot stays held.
  void place_held(size_t robot, const Eigen::Isometry3d& X_WR);
  // Simulation control (doppel-ctl, the viewer; docs/control.md), called between steps. rt-safe.
  // place_robot stands the robot in its initial pose (the file's initial joint angles) with its
  // robot frame at (x, y) heading yaw, at rest, lowered onto the floor; a held robot stays held. Its
  // servos are not touched: once free, they drive the joints to their goals from there.
  void place_robot(size_t robot, double x_m, double y_m, double yaw_rad) noexcept;
  // Puts the robot back as it started: placed at its start placement, motors at ambient
  // temperature, no push, held again if the world holds robots until their first Torque Enable.
  void reset_robot(size_t robot) noexcept;
  // Pushes the robot's root body (the figure's trunk) with `f_W` (N, world frame, through its
  // centre of mass) during the next `steps` steps, e.g. a balance test's shove.
  void push(size_t robot, const Eigen::Vector3d& f_W, uint32_t steps) noexcept;
  // Where the robot is: its robot frame R in the world, inferred from the root body (R's origin is
  // on the floor between the feet when it stands in its initial pose). rt-safe.
  Eigen::Isometry3d robot_pose(size_t robot) const noexcept;
  // Angle between the robot frame's z axis and the vertical, rad (0 upright, pi/2 lying). rt-safe.
  double tilt_rad(size_t robot) const noexcept;
  // Puts the ball (and the extra balls) back where the options placed them, at rest. rt-safe.
  void reset_ball() noexcept;
  // Sets a motor's winding temperature (tests, scenarios). rt-safe.
  void set_motor_temperature(MotorHandle motor, double temperature_c) noexcept;

  // Ground truth. rt-safe. robot_count() counts slots, empty ones (removed robots) included.
  size_t robot_count() const noexcept;
  const RobotModel& robot(size_t robot) const noexcept;
  size_t motor_count() const noexcept;
  // Pose of a body's description frame D (the file's body frame) in the world.
  Eigen::Isometry3d body_pose(size_t robot, size_t body) const noexcept;
  // Centre of mass of a whole robot, world frame.
  Eigen::Vector3d center_of_mass(size_t robot) const noexcept;
  // Joint position of link `link` of a robot (rad or m, the file's convention, not the servo's).
  double link_position(size_t robot, size_t link) const noexcept;
  Eigen::Vector3d ball_position() const noexcept;
  // Every ball: the ball (index 0, if present) and then the extra balls. rt-safe.
  size_t ball_count() const noexcept;
  // Centre of ball `index` (< ball_count()), world frame. rt-safe.
  Eigen::Vector3d ball_position(size_t index) const noexcept;
  // Puts the ball's centre at `position_m` with velocity `velocity_m_s` (a kick, a referee's
  // placement); no-op without a ball. rt-safe.
  void place_ball(const Eigen::Vector3d& position_m, const Eigen::Vector3d& velocity_m_s) noexcept;
  const WorldOptions& options() const noexcept { return options_; }
  std::string_view engine() const noexcept { return backend_->name(); }

  // Writes every visible shape into `view` (robots with team markers, ball, field); robot r has
  // object_id kFirstRobotObjectId + r, the ball kBallObjectId (field.h). The first call
  // sizes view.shapes; later calls with the same view do not allocate. rt-safe after the first call.
  void fill_scene(SceneView& view) const;

 private:
  struct RobotSlot;
  struct MotorSlot;
  struct ImuSlot;
  struct FootSlot;

  void build_robot(size_t index, const RobotPlacement& placement);
  // Removes whatever build_robot made of robot `index` from the engine; marks its devices dead.
  void tear_down(size_t index) noexcept;
  void set_robot_frame(RobotSlot& slot, const Eigen::Isometry3d& X_WR) noexcept;
  static constexpr size_t kEveryRobot = static_cast<size_t>(-1);
  void update_sensors(size_t only = kEveryRobot) noexcept;  // every robot's, or robot `only`'s
  DriveLaw hold_law(double target, double position) const noexcept;
  // While a held robot is handed over: link `link` follows its servo, which has torque.
  bool handed_over(const RobotSlot& robot, size_t link) const noexcept;

  std::unique_ptr<Backend> backend_;
  WorldOptions options_;
  int64_t step_ns_ = 1000000;
  uint64_t steps_ = 0;
  std::vector<RobotSlot> robots_;
  std::vector<MotorSlot> motors_;
  std::vector<ImuSlot> imus_;
  std::vector<FootSlot> feet_;
  std::vector<ContactForce> contact_buffer_;
  int ball_body_ = -1;
  std::vector<int> extra_ball_bodies_;  // WorldOptions::extra_balls, in order
};

}  // namespace doppel::physics
