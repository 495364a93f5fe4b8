#include "physics/world.h"

#include "physics/field.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace doppel::physics {
namespace {

constexpr size_t kContactBufferSize = 64;  // contacts per foot per step that the load cells see
constexpr double kHoldRate_1_s = 20.0;     // how fast a held joint is pulled back to its hold angle
constexpr double kHoldDamping = 50.0;      // N m s/rad: a firm grip, soft enough for the iterative solvers
const Rgb kTeamColours[2] = {kTeamCyan, kTeamMagenta};

// The handle of the motor, IMU or foot slot of device `id` on `bus` of `robot`; nullopt for none. rt-safe.
template <class Handle, class Slot>
std::optional<Handle> find_slot(const std::vector<Slot>& slots, size_t robot, uint32_t bus, uint8_t id) noexcept {
  for (size_t i = 0; i < slots.size(); ++i) {
    if (slots[i].alive && slots[i].robot == robot && slots[i].bus == bus && slots[i].id == id) {
      return Handle{static_cast<uint32_t>(i)};
    }
  }
  return std::nullopt;
}

// What a joint carries, for a load-dependent friction law (M3..M6): the backend bodies beyond it
// (its child and everything further out) whose weight about the joint is the external torque
// tau_e, and the joint's anchor and axis in the child's inertial frame. Empty for the other laws.
struct CarriedLoad {
  std::vector<int> bodies;
  std::vector<double> masses_kg;
  int child_body = 0;
  Eigen::Vector3d anchor_C = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_C = Eigen::Vector3d::UnitZ();
};

// The weight of `load` as a torque about its joint, joint coordinates. rt-safe.
double carried_torque_nm(const Backend& backend, const CarriedLoad& load, double gravity_m_s2) noexcept {
  const BodyReading child = backend.body(load.child_body);
  const Eigen::Vector3d anchor_W = child.X_WB * load.anchor_C;
  const Eigen::Vector3d axis_W = child.X_WB.linear() * load.axis_C;
  Eigen::Vector3d torque_W = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < load.bodies.size(); ++i) {
    const Eigen::Vector3d com_W = backend.body(load.bodies[i]).X_WB.translation();
    torque_W += (com_W - anchor_W).cross(Eigen::Vector3d(0.0, 0.0, -load.masses_kg[i] * gravity_m_s2));
  }
  return axis_W.dot(torque_W);
}

// Lowest z of a shape placed at X_WS.
double lowest_point(const ShapeSpec& s, const Eigen::Isometry3d& X_WS) {
  switch (s.type) {
    case ShapeType::kBox: {
      const Eigen::Vector3d half = 0.5 * s.size_m;
      return X_WS.translation().z() - (X_WS.linear().row(2).cwiseAbs() * half).value();
    }
    case ShapeType::kSphere:
      return X_WS.translation().z() - s.size_m.x();
    case ShapeType::kCylinder:
    case ShapeType::kCapsule: {
      const double axis_z = std::abs(X_WS.linear()(2, 2));
      const double half_axis = 0.5 * s.size_m.y() * axis_z;
      const double rim = s.type == ShapeType::kCapsule ? s.size_m.x() : s.size_m.x() * std::sqrt(std::max(0.0, 1.0 - axis_z * axis_z));
      return X_WS.translation().z() - half_axis - rim;
    }
    case ShapeType::kConvex: {
      double lowest = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector3d& v : s.hull->vertices) lowest = std::min(lowest, (X_WS * v).z());
      return lowest;
    }
    case ShapeType::kRing:
      break;
  }
  return X_WS.translation().z();
}

// Roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll).
void rpy_of(const Eigen::Matrix3d& R, double& roll, double& pitch, double& yaw) {
  pitch = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  roll = std::atan2(R(2, 1), R(2, 2));
  yaw = std::atan2(R(1, 0), R(0, 0));
}

}  // namespace

struct World::RobotSlot {
  bool present = false;               // false: an empty slot (never filled, or the robot was removed)
  RobotModel model;
  int body_count = 0;                 // backend bodies and joints made so far (build_robot)
  int joint_count = 0;
  int first_body = 0;                 // backend index of model body 0
  int first_joint = 0;                // backend index of model link 0
  bool held = false;
  bool release_pending = false;
  int64_t hand_over_end_step = -1;    // handing over (kUntilTorque) until this step; -1 = not
  std::vector<double> hold_position;  // per link, rad or m
  std::vector<int> link_motor;        // per link: motor slot or -1
  std::vector<double> initial_position;    // per link: the file's initial joint positions
  std::vector<Eigen::Isometry3d> initial_X_RB;  // per body: its pose in R in the initial pose
  double floor_z = 0.0;               // height of R above the floor that puts the lowest point on it
  Eigen::Isometry3d start_X_WR = Eigen::Isometry3d::Identity();  // where the robot started
  Eigen::Vector3d push_force = Eigen::Vector3d::Zero();
  uint32_t push_steps = 0;
  int marker_body = 0;                // body that carries the team marker
  Eigen::Isometry3d marker_X_BM = Eigen::Isometry3d::Identity();
  uint8_t team = 0;
};

struct World::MotorSlot {
  bool alive = true;  // false once its robot was removed
  size_t robot = 0;
  int link = 0;       // link index in the robot
  int joint = 0;      // backend joint
  DcMotorParams params;
  double direction = 1.0;
  double offset_rad = 0.0;
  uint32_t bus = 0;
  uint8_t id = 0;
  double supply_v = 0.0;  // its bus' supply voltage
  MotorCommand command;
  DriveLaw law;
  ThermalModel thermal;
  MotorState state;
  CarriedLoad load;  // for a load-dependent friction law only
};

struct World::ImuSlot {
  bool alive = true;
  size_t robot = 0;
  uint32_t bus = 0;
  uint8_t id = 0;
  int body = 0;  // backend body
  Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();
  Eigen::Vector3d v_prev = Eigen::Vector3d::Zero();
  Eigen::Vector3d f_S = Eigen::Vector3d::Zero();  // filtered specific force
  bool has_prev = false;
  ImuState state;
};

struct World::FootSlot {
  bool alive = true;
  size_t robot = 0;
  uint32_t bus = 0;
  uint8_t id = 0;
  int body = 0;  // backend body
  Eigen::Isometry3d X_BD = Eigen::Isometry3d::Identity();
  double x_front = 0.0, x_back = 0.0, y_left = 0.0, y_right = 0.0;  // cell rectangle in D
  FootState state;
};

World::World(std::unique_ptr<Backend> backend, std::vector<RobotModel> robots, std::vector<RobotPlacement> placements,
             WorldOptions options)
    : backend_(std::move(backend)), options_(std::move(options)) {
  if (!backend_) {
    throw std::invalid_argument("World: no physics backend");
  }
  if (robots.size() > kMaxRobotGroups) {
    throw std::invalid_argument("World: at most " + std::to_string(kMaxRobotGroups) + " robots, got " +
                                std::to_string(robots.size()));
  }
  if (!(options_.step_s > 0.0 && options_.step_s <= 0.01)) {
    throw std::invalid_argument("World: step must be within (0, 10 ms], got " + std::to_string(options_.step_s) + " s");
  }
  if (!(options_.supply_voltage_v > 0.0)) {
    throw std::invalid_argument("World: supply voltage must be > 0");
  }
  if (options_.solver_iterations < 1) {
    throw std::invalid_argument("World: solver iterations must be >= 1");
  }
  if (!(options_.hold_hand_over_s >= 0.0 && options_.hold_hand_over_s <= 60.0)) {
    throw std::invalid_argument("World: hold hand-over must be within [0, 60] s");
  }
  step_ns_ = std::llround(options_.step_s * 1e9);
  backend_->init(BackendOptions{options_.gravity_m_s2, options_.solver_iterations, options_.step_s});
  backend_->add_ground(options_.ground);
  for (const VisualShape& shape : options_.field) {
    if (shape.kind == ObjectKind::kCarpet || shape.kind == ObjectKind::kFieldLine || shape.type == ShapeType::kRing) {
      continue;
    }
    backend_->add_static(ShapeSpec{shape.type, shape.X_WS, shape.size_m, shape.hull}, MaterialSpec{0.5, 0.5});
  }
  if (options_.extra_balls.size() > kMaxExtraBalls) {
    throw std::invalid_argument("World: at most " + std::to_string(kMaxExtraBalls) + " extra balls");
  }
  auto add_ball = [this](const BallOptions& ball) {
    if (!(ball.radius_m > 0.0) || !(ball.mass_kg > 0.0) || !std::isfinite(ball.position_m.x()) ||
        !std::isfinite(ball.position_m.y())) {
      throw std::invalid_argument("World: a ball needs a positive radius and mass and a finite position");
    }
    const ShapeSpec sphere{ShapeType::kSphere, Eigen::Isometry3d::Identity(), {ball.radius_m, 0.0, 0.0}, nullptr};
    BodyDesc desc;
    desc.shapes = &sphere;
    desc.shape_count = 1;
    desc.mass_kg = ball.mass_kg;
    desc.inertia_kg_m2.setConstant(2.0 / 3.0 * ball.mass_kg * ball.radius_m * ball.radius_m);  // hollow sphere
    desc.X_WB.translation() = Eigen::Vector3d(ball.position_m.x(), ball.position_m.y(), ball.radius_m);
    desc.material = ball.material;
    desc.group = kGroupBall;
    return backend_->add_body(desc);
  };
  if (options_.ball.present) ball_body_ = add_ball(options_.ball);
  for (const BallOptions& ball : options_.extra_balls) extra_ball_bodies_.push_back(add_ball(ball));
  robots_.reserve(kMaxRobotGroups);  // add_robot never moves a slot: robot() references stay valid
  robots_.resize(robots.size());
  for (size_t r = 0; r < robots.size(); ++r) {
    robots_[r].present = true;
    robots_[r].model = std::move(robots[r]);
    RobotPlacement placement = r < placements.size() ? placements[r] : RobotPlacement{};
    if (r >= placements.size()) {
      placement.position_m = Eigen::Vector3d(0.0, 0.5 * static_cast<double>(r), 0.0);
    }
    build_robot(r, placement);
  }
  backend_->finalize();
  contact_buffer_.resize(kContactBufferSize);
  update_sensors();
}

World::~World() = default;

void World::build_robot(size_t index, const RobotPlacement& placement) {
  RobotSlot& robot = robots_[index];
  const RobotModel& model = robot.model;
  robot.team = placement.team;

  // Initial pose, lowered onto the floor.
  std::vector<double> q(model.links.size());
  for (size_t l = 0; l < q.size(); ++l) {
    q[l] = model.links[l].initial;
  }
  const std::vector<Eigen::Isometry3d> X_RB = body_poses(model, q);
  Eigen::Isometry3d X_WR = Eigen::Isometry3d::Identity();
  X_WR.linear() = Eigen::AngleAxisd(placement.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X_WR.translation() = Eigen::Vector3d(placement.position_m.x(), placement.position_m.y(), 0.0);
  double lowest = std::numeric_limits<double>::infinity();
  double highest = -lowest;
  for (size_t b = 0; b < model.bodies.size(); ++b) {
    for (const ShapeSpec& s : model.bodies[b].shapes) {
      lowest = std::min(lowest, lowest_point(s, X_WR * X_RB[b] * s.X_BS));
    }
    const double top = model.bodies[b].X_RB.translation().z();
    if (top > highest) {
      highest = top;
      robot.marker_body = static_cast<int>(b);
    }
  }
  X_WR.translation().z() -= lowest;
  robot.initial_position = q;
  robot.initial_X_RB = X_RB;
  robot.floor_z = -lowest;
  robot.start_X_WR = X_WR;

  // Team marker: a flat tile on top of the highest body (the head), level at the design pose.
  const BodyModel& marker_body = model.bodies[static_cast<size_t>(robot.marker_body)];
  double half_height = 0.0;
  for (const ShapeSpec& s : marker_body.shapes) {
    half_height = std::max(half_height, s.type == ShapeType::kBox      ? 0.5 * s.size_m.z()
                                        : s.type == ShapeType::kConvex ? s.size_m.z()
                                                                       : s.size_m.x());
  }
  Eigen::Isometry3d X_RM = Eigen::Isometry3d::Identity();
  X_RM.translation() = marker_body.X_RB.translation() + Eigen::Vector3d(0.0, 0.0, half_height + 0.004);
  robot.marker_X_BM = marker_body.X_RB.inverse() * X_RM;

  // Bodies at the design pose, joints, then the initial pose.
  robot.first_body = -1;
  for (size_t b = 0; b < model.bodies.size(); ++b) {
    const BodyModel& body = model.bodies[b];
    BodyDesc desc;
    desc.shapes = body.shapes.data();
    desc.shape_count = body.shapes.size();
    desc.mass_kg = body.mass_kg;
    desc.inertia_kg_m2 = body.inertia_kg_m2;
    desc.X_WB = X_WR * body.X_RB;
    desc.material = body.material;
    desc.group = static_cast<uint32_t>(index);
    // A limb turning at servo speed (5 rad/s) with 1e-4 kg m^2 feels a gyroscopic torque of
    // milli-newton-metres against servo torques of newton-metres: not worth integrating.
    desc.gyroscopic = false;
    desc.self_collide = model.self_collision;
    desc.report_contacts = std::any_of(model.feet.begin(), model.feet.end(),
                                       [&](const FootModel& f) { return f.body == static_cast<int>(b); });
    const int id = backend_->add_body(desc);
    if (b == 0) {
      robot.first_body = id;
    }
    ++robot.body_count;
  }
  for (const auto& [a, b] : model.collision_exempt) {
    backend_->exclude_collision(robot.first_body + a, robot.first_body + b);
  }
  robot.link_motor.assign(model.links.size(), -1);
  for (size_t l = 0; l < model.links.size(); ++l) {
    const LinkModel& link = model.links[l];
    JointDesc desc;
    desc.type = link.type;
    desc.parent = robot.first_body + link.parent;
    desc.child = robot.first_body + link.child;
    desc.anchor_W = X_WR * link.anchor_R;
    desc.axis_W = X_WR.linear() * link.axis_R;
    desc.limited = link.limited;
    desc.lower = link.lower;
    desc.upper = link.upper;
    const int id = backend_->add_joint(desc);
    if (l == 0) {
      robot.first_joint = id;
    }
    ++robot.joint_count;
  }
  for (size_t b = 0; b < model.bodies.size(); ++b) {
    backend_->set_body_state(robot.first_body + static_cast<int>(b), X_WR * X_RB[b], Eigen::Vector3d::Zero(),
                             Eigen::Vector3d::Zero());
  }
  robot.hold_position = q;

  for (const MotorModel& m : model.motors) {
    MotorSlot slot{true,
                   index,
                   m.link,
                   robot.first_joint + m.link,
                   m.params,
                   m.direction,
                   m.offset_rad,
                   m.bus,
                   m.id,
                   m.supply_voltage_v > 0.0 ? m.supply_voltage_v : options_.supply_voltage_v,
                   MotorCommand{},
                   DriveLaw{},
                   ThermalModel(m.params, options_.ambient_c, options_.step_s),
                   MotorState{},
                   CarriedLoad{}};
    slot.state.temperature_c = options_.ambient_c;
    slot.state.voltage_v = slot.supply_v;
    slot.state.position_rad = m.direction * q[static_cast<size_t>(m.link)] + m.offset_rad;
    if (load_dependent(m.params.friction.law)) {
      const LinkModel& link = model.links[static_cast<size_t>(m.link)];
      const Eigen::Isometry3d& X_RC = model.bodies[static_cast<size_t>(link.child)].X_RB;
      slot.load.child_body = robot.first_body + link.child;
      slot.load.anchor_C = X_RC.inverse() * link.anchor_R;
      slot.load.axis_C = X_RC.linear().transpose() * link.axis_R;
      // Links come parent before child, so one pass collects the subtree under the joint.
      std::vector<bool> carried(model.bodies.size(), false);
      carried[static_cast<size_t>(link.child)] = true;
      for (const LinkModel& other : model.links) {
        if (carried[static_cast<size_t>(other.parent)]) carried[static_cast<size_t>(other.child)] = true;
      }
      for (size_t b = 0; b < model.bodies.size(); ++b) {
        if (!carried[b]) continue;
        slot.load.bodies.push_back(robot.first_body + static_cast<int>(b));
        slot.load.masses_kg.push_back(model.bodies[b].mass_kg);
      }
    }
    robot.link_motor[static_cast<size_t>(m.link)] = static_cast<int>(motors_.size());
    motors_.push_back(slot);
  }
  for (const ImuModel& s : model.imus) {
    ImuSlot slot;
    slot.robot = index;
    slot.bus = s.bus;
    slot.id = s.id;
    slot.body = robot.first_body + s.body;
    slot.X_BS = model.bodies[static_cast<size_t>(s.body)].X_BD * s.X_DS;
    imus_.push_back(slot);
  }
  for (const FootModel& s : model.feet) {
    FootSlot slot;
    slot.robot = index;
    slot.bus = s.bus;
    slot.id = s.id;
    slot.body = robot.first_body + s.body;
    slot.X_BD = model.bodies[static_cast<size_t>(s.body)].X_BD;
    slot.x_front = 0.5 * (s.cell_D[0].x() + s.cell_D[1].x());
    slot.x_back = 0.5 * (s.cell_D[2].x() + s.cell_D[3].x());
    slot.y_left = 0.5 * (s.cell_D[0].y() + s.cell_D[2].y());
    slot.y_right = 0.5 * (s.cell_D[1].y() + s.cell_D[3].y());
    feet_.push_back(slot);
  }

  if (options_.hold == HoldMode::kUntilTorque) {
    robot.held = true;
    backend_->set_pinned(robot.first_body + model.root, true);
  }
}

size_t World::add_robot(RobotModel model, const RobotPlacement& placement) {
  size_t index = 0;
  while (index < robots_.size() && robots_[index].present) ++index;
  if (index >= kMaxRobotGroups) {
    throw std::invalid_argument("World: at most " + std::to_string(kMaxRobotGroups) + " robots");
  }
  if (index == robots_.size()) robots_.emplace_back();  // within the capacity reserved at construction
  RobotSlot& slot = robots_[index];
  slot = RobotSlot{};
  slot.present = true;
  slot.model = std::move(model);
  const size_t motors = motors_.size(), imus = imus_.size(), feet = feet_.size();
  try {
    build_robot(index, placement);
    backend_->finalize();
  } catch (...) {
    tear_down(index);
    // The new robot's slots only: the others' handles are unchanged.
    motors_.erase(motors_.begin() + static_cast<std::ptrdiff_t>(motors), motors_.end());
    imus_.erase(imus_.begin() + static_cast<std::ptrdiff_t>(imus), imus_.end());
    feet_.erase(feet_.begin() + static_cast<std::ptrdiff_t>(feet), feet_.end());
    slot = RobotSlot{};
    throw;
  }
  update_sensors(index);
  return index;
}

void World::remove_robot(size_t robot) {
  if (!has_robot(robot)) {
    throw std::invalid_argument("World: no robot " + std::to_string(robot) + " to remove");
  }
  tear_down(robot);
  robots_[robot] = RobotSlot{};
}

void World::tear_down(size_t index) noexcept {
  RobotSlot& slot = robots_[index];
  for (int j = 0; j < slot.joint_count; ++j) backend_->remove_joint(slot.first_joint + j);
  for (int b = 0; b < slot.body_count; ++b) backend_->remove_body(slot.first_body + b);
  slot.joint_count = slot.body_count = 0;
  for (MotorSlot& m : motors_) {
    if (m.robot == index) m.alive = false;
  }
  for (ImuSlot& imu : imus_) {
    if (imu.robot == index) imu.alive = false;
  }
  for (FootSlot& foot : feet_) {
    if (foot.robot == index) foot.alive = false;
  }
}

bool World::has_robot(size_t robot) const noexcept { return robot < robots_.size() && robots_[robot].present; }

std::optional<MotorHandle> World::find_motor(size_t robot, uint32_t bus, uint8_t id) const noexcept {
  return find_slot<MotorHandle>(motors_, robot, bus, id);
}

std::optional<ImuHandle> World::find_imu(size_t robot, uint32_t bus, uint8_t id) const noexcept {
  return find_slot<ImuHandle>(imus_, robot, bus, id);
}

std::optional<FootHandle> World::find_foot(size_t robot, uint32_t bus, uint8_t id) const noexcept {
  return find_slot<FootHandle>(feet_, robot, bus, id);
}

void World::set_motor(MotorHandle motor, const MotorCommand& command) noexcept {
  if (motor.index >= motors_.size() || !motors_[motor.index].alive) {
    return;
  }
  MotorSlot& slot = motors_[motor.index];
  slot.command = command;
  RobotSlot& robot = robots_[slot.robot];
  if (command.enabled && robot.held && options_.hold == HoldMode::kUntilTorque && robot.hand_over_end_step < 0) {
    robot.hand_over_end_step = static_cast<int64_t>(steps_) +
                               static_cast<int64_t>(std::llround(options_.hold_hand_over_s / options_.step_s));
  }
}

bool World::handed_over(const RobotSlot& robot, size_t link) const noexcept {
  const int m = robot.link_motor[link];
  return robot.hand_over_end_step >= 0 && m >= 0 && motors_[static_cast<size_t>(m)].command.enabled;
}

DriveLaw World::hold_law(double target, double position) const noexcept {
  return DriveLaw{kHoldRate_1_s * (target - position), kHoldDamping, options_.hold_torque_nm};
}

void World::hold(size_t robot) noexcept {
  if (!has_robot(robot)) {
    return;
  }
  RobotSlot& slot = robots_[robot];
  for (size_t l = 0; l < slot.model.links.size(); ++l) {
    slot.hold_position[l] = backend_->joint(slot.first_joint + static_cast<int>(l)).position;
  }
  slot.held = true;
  slot.release_pending = false;
  slot.hand_over_end_step = -1;
  backend_->set_pinned(slot.first_body + slot.model.root, true);
}

void World::release(size_t robot) noexcept {
  if (!has_robot(robot)) {
    return;
  }
  RobotSlot& slot = robots_[robot];
  slot.held = false;
  slot.release_pending = false;
  slot.hand_over_end_step = -1;
  backend_->set_pinned(slot.first_body + slot.model.root, false);
  for (size_t l = 0; l < slot.model.links.size(); ++l) {
    backend_->set_drive(slot.first_joint + static_cast<int>(l), DriveLaw{});
  }
}

bool World::held(size_t robot) const noexcept { return has_robot(robot) && robots_[robot].held; }

void World::place_held(size_t robot, const Eigen::Isometry3d& X_WR) {
  if (!has_robot(robot)) {
    throw std::invalid_argument("World::place_held: no robot " + std::to_string(robot));
  }
  RobotSlot& slot = robots_[robot];
  if (!slot.held) {
    hold(robot);
  }
  const std::vector<Eigen::Isometry3d> X_RB = body_poses(slot.model, slot.hold_position);
  backend_->set_pinned(slot.first_body + slot.model.root, false);
  for (size_t b = 0; b < X_RB.size(); ++b) {
    backend_->set_body_state(slot.first_body + static_cast<int>(b), X_WR * X_RB[b], Eigen::Vector3d::Zero(),
                             Eigen::Vector3d::Zero());
  }
  backend_->set_pinned(slot.first_body + slot.model.root, true);
  for (ImuSlot& imu : imus_) {
    if (imu.alive && imu.robot == robot) {
      imu.has_prev = false;
    }
  }
  update_sensors();
}

void World::set_robot_frame(RobotSlot& slot, const Eigen::Isometry3d& X_WR) noexcept {
  const int root = slot.first_body + slot.model.root;
  backend_->set_pinned(root, false);
  for (size_t b = 0; b < slot.initial_X_RB.size(); ++b) {
    backend_->set_body_state(slot.first_body + static_cast<int>(b), X_WR * slot.initial_X_RB[b],
                             Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  }
  std::copy(slot.initial_position.begin(), slot.initial_position.end(), slot.hold_position.begin());
  if (slot.held) {
    backend_->set_pinned(root, true);
  }
  const size_t robot = static_cast<size_t>(&slot - robots_.data());
  for (ImuSlot& imu : imus_) {
    if (imu.alive && imu.robot == robot) imu.has_prev = false;
  }
  for (MotorSlot& m : motors_) {
    if (m.alive && m.robot == robot) {
      m.state.position_rad = m.direction * slot.initial_position[static_cast<size_t>(m.link)] + m.offset_rad;
      m.state.velocity_rad_s = 0.0;
    }
  }
  update_sensors();
}

void World::place_robot(size_t robot, double x_m, double y_m, double yaw_rad) noexcept {
  if (!has_robot(robot)) return;
  RobotSlot& slot = robots_[robot];
  Eigen::Isometry3d X_WR = Eigen::Isometry3d::Identity();
  X_WR.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  X_WR.translation() = Eigen::Vector3d(x_m, y_m, slot.floor_z);
  set_robot_frame(slot, X_WR);
}

void World::reset_robot(size_t robot) noexcept {
  if (!has_robot(robot)) return;
  RobotSlot& slot = robots_[robot];
  slot.push_steps = 0;
  slot.release_pending = false;
  slot.hand_over_end_step = -1;
  slot.held = options_.hold == HoldMode::kUntilTorque;
  if (!slot.held) {
    release(robot);
  }
  set_robot_frame(slot, slot.start_X_WR);
  for (MotorSlot& m : motors_) {
    if (m.alive && m.robot == robot) {
      m.command = MotorCommand{};
      m.thermal.set_temperature_c(options_.ambient_c);
      m.state.temperature_c = options_.ambient_c;
    }
  }
}

void World::push(size_t robot, const Eigen::Vector3d& f_W, uint32_t steps) noexcept {
  if (!has_robot(robot)) return;
  robots_[robot].push_force = f_W;
  robots_[robot].push_steps = steps;
}

Eigen::Isometry3d World::robot_pose(size_t robot) const noexcept {
  if (!has_robot(robot)) return Eigen::Isometry3d::Identity();
  const RobotSlot& slot = robots_[robot];
  const Eigen::Isometry3d X_WB = backend_->body(slot.first_body + slot.model.root).X_WB;
  return X_WB * slot.initial_X_RB[static_cast<size_t>(slot.model.root)].inverse();
}

double World::tilt_rad(size_t robot) const noexcept {
  const double up = std::clamp(robot_pose(robot).linear()(2, 2), -1.0, 1.0);
  return std::acos(up);
}

void World::reset_ball() noexcept {
  Eigen::Vector3d p = options_.ball.position_m;
  p.z() = options_.ball.radius_m;
  place_ball(p, Eigen::Vector3d::Zero());
  for (size_t i = 0; i < extra_ball_bodies_.size(); ++i) {
    const BallOptions& ball = options_.extra_balls[i];
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translation() = Eigen::Vector3d(ball.position_m.x(), ball.position_m.y(), ball.radius_m);
    backend_->set_body_state(extra_ball_bodies_[i], X, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  }
}

void World::set_motor_temperature(MotorHandle motor, double temperature_c) noexcept {
  if (motor.index < motors_.size()) {
    motors_[motor.index].thermal.set_temperature_c(temperature_c);
    motors_[motor.index].state.temperature_c = temperature_c;
  }
}

void World::step() noexcept {
  for (size_t r = 0; r < robots_.size(); ++r) {
    RobotSlot& robot = robots_[r];
    if (!robot.present) continue;
    if (robot.held && robot.hand_over_end_step >= 0) {
      bool all_on = true;
      for (const int m : robot.link_motor) {
        all_on = all_on && (m < 0 || motors_[static_cast<size_t>(m)].command.enabled);
      }
      robot.release_pending = all_on || static_cast<int64_t>(steps_) >= robot.hand_over_end_step;
    }
    if (robot.release_pending) {
      release(r);
    }
    if (!robot.held) {
      continue;
    }
    for (size_t l = 0; l < robot.model.links.size(); ++l) {
      const JointType type = robot.model.links[l].type;
      if (handed_over(robot, l)) {
        continue;  // its servo drives it
      }
      if (type == JointType::kRevolute || type == JointType::kPrismatic) {
        const int joint = robot.first_joint + static_cast<int>(l);
        backend_->set_drive(joint, hold_law(robot.hold_position[l], backend_->joint(joint).position));
      }
    }
  }
  for (MotorSlot& m : motors_) {
    if (!m.alive) continue;
    if (robots_[m.robot].held && !handed_over(robots_[m.robot], static_cast<size_t>(m.link))) {
      m.law = DriveLaw{};
      continue;
    }
    // The law in servo coordinates, turned into the joint's. A load-dependent friction law takes
    // the motor's torque of the last step and the weight of what the joint carries.
    const double external_nm =
        m.load.bodies.empty() ? 0.0 : m.direction * carried_torque_nm(*backend_, m.load, options_.gravity_m_s2);
    const DriveLaw servo =
        motor_drive(m.params, m.command, m.supply_v, m.state.velocity_rad_s, m.state.torque_nm, external_nm);
    const bool friction_on = !m.command.enabled || options_.powered_gear_friction || m.params.powered_friction;
    m.law = DriveLaw{m.direction * servo.target_velocity, servo.damping, servo.max_torque,
                     friction_on ? servo.friction_torque : 0.0};
    backend_->set_drive(m.joint, m.law);
  }

  for (RobotSlot& robot : robots_) {
    if (robot.present && robot.push_steps > 0) {
      backend_->add_force(robot.first_body + robot.model.root, robot.push_force);
      --robot.push_steps;
    }
  }
  backend_->step(options_.step_s);
  ++steps_;

  for (MotorSlot& m : motors_) {
    if (!m.alive) continue;
    const JointReading reading = backend_->joint(m.joint);
    const double joint_torque = drive_torque(m.law, reading.velocity);
    m.thermal.step(joint_torque);
    MotorState& s = m.state;
    s.position_rad = m.direction * reading.position + m.offset_rad;
    s.velocity_rad_s = m.direction * reading.velocity;
    s.torque_nm = m.direction * joint_torque;
    const double full = max_torque_nm(m.params, m.supply_v);
    s.torque_ratio = full > 0.0 ? std::clamp(s.torque_nm / full, -1.0, 1.0) : 0.0;
    s.current_a = s.torque_nm / m.params.torque_constant_nm_a;
    // An ideal H-bridge passes the motor's electrical power from the supply: V_s i_s = (R i + ke w) i.
    const double motor_v = s.current_a * m.params.resistance_ohm + m.params.back_emf_v_s_rad * s.velocity_rad_s;
    s.supply_current_a = m.supply_v > 0.0 ? motor_v * s.current_a / m.supply_v : 0.0;
    s.temperature_c = m.thermal.temperature_c();
    s.voltage_v = m.supply_v;
  }
  update_sensors();
}

void World::update_sensors(size_t only) noexcept {
  const int64_t now_ns = time_ns();
  const Eigen::Vector3d up_g(0.0, 0.0, options_.gravity_m_s2);
  const double accel_alpha = options_.step_s / (options_.imu_accel_filter_s + options_.step_s);
  for (ImuSlot& imu : imus_) {
    if (!imu.alive || (only != kEveryRobot && imu.robot != only)) continue;
    const BodyReading body = backend_->body(imu.body);
    const Eigen::Isometry3d X_WS = body.X_WB * imu.X_BS;
    const Eigen::Matrix3d R_SW = X_WS.linear().transpose();
    const Eigen::Vector3d v_S = body.v_WB_W + body.w_WB_W.cross(X_WS.translation() - body.X_WB.translation());
    const Eigen::Vector3d a_W = imu.has_prev ? Eigen::Vector3d((v_S - imu.v_prev) / options_.step_s) : Eigen::Vector3d::Zero();
    const Eigen::Vector3d raw_S = R_SW * (a_W + up_g);
    imu.f_S = imu.has_prev ? Eigen::Vector3d(imu.f_S + accel_alpha * (raw_S - imu.f_S)) : raw_S;
    imu.v_prev = v_S;
    imu.has_prev = true;
    const Eigen::Vector3d w_S = R_SW * body.w_WB_W;
    const Eigen::Vector3d& f_S = imu.f_S;
    ImuState& s = imu.state;
    rpy_of(X_WS.linear(), s.roll_rad, s.pitch_rad, s.yaw_rad);
    s.w_WS_S_rad_s = {w_S.x(), w_S.y(), w_S.z()};
    s.a_WS_S_m_s2 = {f_S.x(), f_S.y(), f_S.z()};
    s.sim_time_ns = now_ns;
  }
  for (FootSlot& foot : feet_) {
    if (!foot.alive || (only != kEveryRobot && foot.robot != only)) continue;
    const BodyReading body = backend_->body(foot.body);
    const Eigen::Isometry3d X_WD = body.X_WB * foot.X_BD;
    const Eigen::Isometry3d X_DW = X_WD.inverse();
    const Eigen::Vector3d z_D = X_WD.linear().col(2);
    const size_t n = backend_->contacts(foot.body, contact_buffer_.data(), contact_buffer_.size());
    std::array<double, 4> cells{};
    for (size_t c = 0; c < n; ++c) {
      const double normal = contact_buffer_[c].f_W.dot(z_D);
      if (!(normal > 0.0)) {
        continue;
      }
      // Bilinear share of the four corners: the shares sum to 1 and keep the centre of pressure.
      const Eigen::Vector3d p = X_DW * contact_buffer_[c].p_W;
      const double u = std::clamp((p.x() - foot.x_back) / (foot.x_front - foot.x_back), 0.0, 1.0);
      const double v = std::clamp((p.y() - foot.y_right) / (foot.y_left - foot.y_right), 0.0, 1.0);
      cells[0] += normal * u * v;
      cells[1] += normal * u * (1.0 - v);
      cells[2] += normal * (1.0 - u) * v;
      cells[3] += normal * (1.0 - u) * (1.0 - v);
    }
    foot.state.force_n = cells;
    foot.state.sim_time_ns = now_ns;
  }
}

MotorState World::motor(MotorHandle motor) const noexcept {
  return motor.index < motors_.size() ? motors_[motor.index].state : MotorState{};
}

ImuState World::imu(ImuHandle imu) const noexcept { return imu.index < imus_.size() ? imus_[imu.index].state : ImuState{}; }

FootState World::foot(FootHandle foot) const noexcept {
  return foot.index < feet_.size() ? feet_[foot.index].state : FootState{};
}

size_t World::robot_count() const noexcept { return robots_.size(); }

size_t World::motor_count() const noexcept { return motors_.size(); }

const RobotModel& World::robot(size_t robot) const noexcept { return robots_[robot].model; }

Eigen::Isometry3d World::body_pose(size_t robot, size_t body) const noexcept {
  if (!has_robot(robot)) return Eigen::Isometry3d::Identity();
  const RobotSlot& slot = robots_[robot];
  return backend_->body(slot.first_body + static_cast<int>(body)).X_WB * slot.model.bodies[body].X_BD;
}

Eigen::Vector3d World::center_of_mass(size_t robot) const noexcept {
  if (!has_robot(robot)) return Eigen::Vector3d::Zero();
  const RobotSlot& slot = robots_[robot];
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (size_t b = 0; b < slot.model.bodies.size(); ++b) {
    sum += slot.model.bodies[b].mass_kg * backend_->body(slot.first_body + static_cast<int>(b)).X_WB.translation();
  }
  return sum / slot.model.mass_kg;
}

double World::link_position(size_t robot, size_t link) const noexcept {
  if (!has_robot(robot)) return 0.0;
  const RobotSlot& slot = robots_[robot];
  return backend_->joint(slot.first_joint + static_cast<int>(link)).position;
}

Eigen::Vector3d World::ball_position() const noexcept {
  return ball_body_ >= 0 ? Eigen::Vector3d(backend_->body(ball_body_).X_WB.translation()) : Eigen::Vector3d::Zero();
}

size_t World::ball_count() const noexcept { return (ball_body_ >= 0 ? 1U : 0U) + extra_ball_bodies_.size(); }

Eigen::Vector3d World::ball_position(size_t index) const noexcept {
  const size_t first_extra = ball_body_ >= 0 ? 1U : 0U;
  if (index < first_extra) return ball_position();
  if (index - first_extra >= extra_ball_bodies_.size()) return Eigen::Vector3d::Zero();
  return backend_->body(extra_ball_bodies_[index - first_extra]).X_WB.translation();
}

void World::place_ball(const Eigen::Vector3d& position_m, const Eigen::Vector3d& velocity_m_s) noexcept {
  if (ball_body_ < 0) return;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = position_m;
  backend_->set_body_state(ball_body_, X, velocity_m_s, Eigen::Vector3d::Zero());
}

void World::fill_scene(SceneView& view) const {
  size_t count = options_.field.size() + ball_count();
  for (const RobotSlot& robot : robots_) {
    if (!robot.present) continue;
    for (const BodyModel& body : robot.model.bodies) {
      count += body.shapes.size();
    }
    ++count;  // team marker
  }
  view.shapes.resize(count);
  size_t i = 0;
  for (size_t r = 0; r < robots_.size(); ++r) {
    const RobotSlot& robot = robots_[r];
    if (!robot.present) continue;
    for (size_t b = 0; b < robot.model.bodies.size(); ++b) {
      const BodyModel& body = robot.model.bodies[b];
      const Eigen::Isometry3d X_WB = backend_->body(robot.first_body + static_cast<int>(b)).X_WB;
      for (const ShapeSpec& s : body.shapes) {
        view.shapes[i++] = VisualShape{s.type, ObjectKind::kRobotBody, X_WB * s.X_BS, s.size_m, body.colour,
                                       static_cast<uint16_t>(kFirstRobotObjectId + r), s.hull};
      }
    }
    const Eigen::Isometry3d X_WB = backend_->body(robot.first_body + robot.marker_body).X_WB;
    view.shapes[i++] = VisualShape{ShapeType::kBox, ObjectKind::kTeamMarker, X_WB * robot.marker_X_BM,
                                   Eigen::Vector3d(0.05, 0.05, 0.008), kTeamColours[robot.team & 1U],
                                   static_cast<uint16_t>(kFirstRobotObjectId + r), nullptr};
  }
  if (ball_body_ >= 0) {
    view.shapes[i++] = VisualShape{ShapeType::kSphere, ObjectKind::kBall, backend_->body(ball_body_).X_WB,
                                   Eigen::Vector3d(options_.ball.radius_m, 0.0, 0.0), kBallOrange, kBallObjectId, nullptr};
  }
  for (size_t b = 0; b < extra_ball_bodies_.size(); ++b) {
    view.shapes[i++] = VisualShape{ShapeType::kSphere, ObjectKind::kBall, backend_->body(extra_ball_bodies_[b]).X_WB,
                                   Eigen::Vector3d(options_.extra_balls[b].radius_m, 0.0, 0.0), kBallOrange,
                                   static_cast<uint16_t>(kBallObjectId + 1 + b), nullptr};
  }
  for (const VisualShape& shape : options_.field) {
    view.shapes[i++] = shape;
  }
  view.sim_time_s = time_s();
}

}  // namespace doppel::physics
