#pragma once
// The engine-neutral contract between World and a physics engine: rigid bodies, joints with an
// implicit drive law, static shapes, a ground plane, contact forces. An engine backend (ODE in
// physics_ode, Bullet in physics_bullet) is the only code that includes an engine header. Sizes are
// fixed by the add_* calls before finalize(); after that the backend only steps and reports, and
// must not allocate (World's allocation test checks it on both engines), except in the run-time
// changes below (a robot added or removed between two steps), which may.

#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string_view>

#include "physics/dc_motor.h"
#include "physics/robot_model.h"

namespace doppel::physics {

struct BackendOptions {
  double gravity_m_s2 = 9.80665;  // along -z
  int solver_iterations = 20;     // iterative constraint solver sweeps per step
  double step_s = 0.001;          // the fixed step the backend will be stepped with
};

// Collision groups: one robot's parts form a group; they collide with each other only when created
// with self_collide, and then not in the pairs given to exclude_collision().
inline constexpr uint32_t kGroupStatic = 7;  // field objects and the ground
inline constexpr uint32_t kGroupBall = 6;    // free objects
inline constexpr uint32_t kMaxRobotGroups = 6;

struct BodyDesc {
  const ShapeSpec* shapes = nullptr;   // in the inertial frame B
  size_t shape_count = 0;
  double mass_kg = 1.0;
  Eigen::Vector3d inertia_kg_m2 = Eigen::Vector3d::Ones();  // principal moments about B's axes
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();   // pose at creation
  MaterialSpec material;
  uint32_t group = kGroupBall;         // collision group, 0..7
  bool report_contacts = false;        // contacts() will be asked for this body
  bool gyroscopic = true;              // integrate the gyroscopic torque w x (I w)
  bool self_collide = false;           // collides with other self_collide bodies of its group
};

struct JointDesc {
  JointType type = JointType::kRevolute;
  int parent = -1;                     // body index, -1 = the world
  int child = -1;                      // body index
  Eigen::Vector3d anchor_W = Eigen::Vector3d::Zero();  // at creation (position 0)
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();   // unit, at creation
  bool limited = false;
  double lower = 0.0;                  // rad or m
  double upper = 0.0;                  // rad or m
};

// Position and speed of a revolute (rad, rad/s) or prismatic (m, m/s) joint: the child relative to
// the parent about / along the axis, 0 where the joint was created.
struct JointReading {
  double position = 0.0;
  double velocity = 0.0;
};

struct BodyReading {
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();  // pose of B
  Eigen::Vector3d v_WB_W = Eigen::Vector3d::Zero();        // velocity of B's origin, world frame
  Eigen::Vector3d w_WB_W = Eigen::Vector3d::Zero();        // angular velocity, world frame
};

struct ContactForce {
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();  // contact point
  Eigen::Vector3d f_W = Eigen::Vector3d::Zero();  // force on the reporting body, N
};

class Backend {
 public:
  virtual ~Backend() = default;

  // Setup (may throw std::runtime_error / std::invalid_argument, may allocate).
  virtual void init(const BackendOptions& options) = 0;
  virtual int add_body(const BodyDesc& body) = 0;                          // returns the body index
  virtual void add_static(const ShapeSpec& shape_in_W, const MaterialSpec& material) = 0;  // X_BS = pose in W
  virtual void add_ground(const MaterialSpec& material) = 0;               // plane z = 0
  virtual int add_joint(const JointDesc& joint) = 0;                       // returns the joint index
  virtual void exclude_collision(int body_a, int body_b) = 0;              // this pair never collides
  virtual void finalize() = 0;                                             // no add_* after this
  // Robots added and removed while the world runs (World::add_robot / remove_robot), between two
  // steps; these calls may allocate and throw. After finalize(), add_body / add_joint /
  // exclude_collision followed by another finalize() bring new bodies in. remove_joint takes a
  // joint out for good, remove_body a body (its joints first, and its pin): it collides with
  // nothing any more. The indices of everything else stay valid; a removed index is never reused
  // and must not be passed to any call again.
  virtual void remove_joint(int joint) = 0;
  virtual void remove_body(int body) = 0;

  // Setup or between steps. rt-safe unless noted.
  virtual void set_body_state(int body, const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& v_WB_W,
                              const Eigen::Vector3d& w_WB_W) noexcept = 0;
  // Pins a body to the world at its present pose (a handler's grip), or lets it go.
  virtual void set_pinned(int body, bool pinned) noexcept = 0;
  // The drive law of a revolute/prismatic joint for the next steps (max_torque 0 = free joint).
  virtual void set_drive(int joint, const DriveLaw& law) noexcept = 0;
  // A force through the body's centre of mass, world frame, N, for the next step only (a push).
  virtual void add_force(int body, const Eigen::Vector3d& f_W) noexcept = 0;

  // One fixed step of `dt_s` seconds. rt-safe.
  virtual void step(double dt_s) noexcept = 0;

  // Readouts after a step. rt-safe.
  virtual JointReading joint(int joint) const noexcept = 0;
  virtual BodyReading body(int body) const noexcept = 0;
  // Contact forces on a body created with report_contacts, from the last step; writes up to
  // `capacity` and returns how many were written.
  virtual size_t contacts(int body, ContactForce* out, size_t capacity) const noexcept = 0;

  virtual std::string_view name() const noexcept = 0;
};

}  // namespace doppel::physics
