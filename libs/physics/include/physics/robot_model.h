#pragma once
// A robot's body compiled from the figure of its Robot Description File and checked: every body
// named once with a shape and a mass, every reference to a body, material or bus device resolved,
// the links forming one tree (N bodies, N - 1 links), every servo driven by one link only. Mass
// properties are computed here, so backends receive plain rigid bodies. No engine is involved.
// Setup code: errors throw std::invalid_argument "file:line:column: Type.field: what".

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "physics/convex_hull.h"
#include "physics/dc_motor.h"
#include "physics/scene_view.h"
#include "proto/robot_file.h"

namespace doppel::physics {

struct MaterialSpec {
  double friction = 0.8;     // Coulomb coefficient (combined by product with the other surface)
  double restitution = 0.0;  // 0..1 (combined by product)
};

// One primitive of a body, in the body's inertial frame B.
struct ShapeSpec {
  ShapeType type = ShapeType::kBox;                        // kBox, kSphere, kCylinder, kCapsule or kConvex
  Eigen::Isometry3d X_BS = Eigen::Isometry3d::Identity();  // shape frame S in B
  Eigen::Vector3d size_m = Eigen::Vector3d::Zero();        // as VisualShape::size_m
  std::shared_ptr<const ConvexHull> hull;                  // kConvex: the hull in S
};

struct BodyModel {
  std::string name;                                        // from the file
  std::vector<ShapeSpec> shapes;                           // in B
  double mass_kg = 0.0;                                    // > 0
  Eigen::Vector3d inertia_kg_m2 = Eigen::Vector3d::Zero(); // principal moments about B's axes
  Eigen::Isometry3d X_RB = Eigen::Isometry3d::Identity();  // inertial frame B (origin at the centre of
                                                           // mass, principal axes) in the robot frame, design pose
  Eigen::Isometry3d X_BD = Eigen::Isometry3d::Identity();  // the file's body frame D in B (sensors are given in D)
  MaterialSpec material;                                   // surface
  Rgb colour;                                              // for renderers
};
// A body may have no shape when its file gives explicit mass properties (Body.inertial): it then
// never collides (engines give it an empty collision shape).

enum class JointType : uint8_t { kRevolute, kPrismatic, kSpherical, kFixed };

struct MotorModel {
  uint32_t bus = 0;        // bus index in the description
  uint8_t id = 0;          // servo bus ID
  std::string model;       // servo model, as its bus device names it
  int link = -1;           // index of the driven link
  DcMotorParams params;    // motor constants (model defaults with the file's overrides)
  double direction = 1.0;  // +1, or -1 when reversed: servo angle = direction * q + offset
  double offset_rad = 0.0; // servo angle at link position 0
  double supply_voltage_v = 0.0;  // its bus' Bus.supply_voltage_v; 0 = unset (WorldOptions::supply_voltage_v)
};

struct LinkModel {
  std::string name;                                    // from the file
  JointType type = JointType::kRevolute;               // joint kind
  int parent = -1;                                     // body index
  int child = -1;                                      // body index
  Eigen::Vector3d anchor_R = Eigen::Vector3d::Zero();  // joint point, robot frame, design pose, m
  Eigen::Vector3d axis_R = Eigen::Vector3d::UnitZ();   // unit axis, robot frame, design pose
  bool limited = false;                                // lower/upper valid
  double lower = 0.0;                                  // rad (revolute) or m (prismatic)
  double upper = 0.0;                                  // rad or m
  double initial = 0.0;                                // start position, rad or m
  int motor = -1;                                      // index into RobotModel::motors, -1 = passive
};

struct ImuModel {
  std::string name;                                        // from the file
  int body = -1;                                           // body index
  Eigen::Isometry3d X_DS = Eigen::Isometry3d::Identity();  // sensor frame S in the file's body frame D
  uint32_t bus = 0;                                        // bus index
  uint8_t id = 0;                                          // bus ID
};

struct FootModel {
  std::string name;                     // from the file
  int body = -1;                        // body index
  std::array<Eigen::Vector3d, 4> cell_D; // load cells in D, board order FL, FR, BL, BR
  uint32_t bus = 0;                     // bus index
  uint8_t id = 0;                       // bus ID
};

struct CameraModel {
  std::string name;                                        // from the file
  int body = -1;                                           // body index
  Eigen::Isometry3d X_DC = Eigen::Isometry3d::Identity();  // camera frame C in D
};

struct RobotModel {
  std::string name;                 // RobotDescription.name
  std::string source;               // file it came from
  std::vector<BodyModel> bodies;    // file order
  std::vector<LinkModel> links;     // parent before child (tree order from the root)
  std::vector<MotorModel> motors;   // file order of their links
  std::vector<ImuModel> imus;       // file order
  std::vector<FootModel> feet;      // file order
  std::vector<CameraModel> cameras; // file order
  int root = 0;                     // the body that is no link's child
  double mass_kg = 0.0;             // total
  bool self_collision = true;       // Figure.self_collision: bodies of this robot collide with each other
  // Body pairs (lower index first) that never collide with each other: joined by a link, or
  // touching or overlapping (within 2 mm) in the initial pose, where a contact could only push
  // the parts apart. Sorted.
  std::vector<std::pair<int, int>> collision_exempt;
};

// The motor constants of a servo model, nullopt when `model` is no servo with known constants.
// `bam_model` 0 asks for the model's defaults, 1..6 for its BAM identification M1..M6 (nullopt
// when it has none). The caller supplies it (body/motor_params.h reads the device model
// registry): physics receives numbers, never knows model names.
using MotorCatalog = std::function<std::optional<DcMotorParams>(std::string_view model, int bam_model)>;

// Compiles and checks the figure of `file`; each motor's constants come from `motors` (by the
// model of its bus device), then the file's overrides. Throws std::invalid_argument naming file,
// line and field (no figure, unknown body/material/device, loop, motor ID used twice, missing
// mass, a device without motor constants, ...).
RobotModel compile_robot(const proto::RobotFile& file, const MotorCatalog& motors);

// Checks only (same errors as compile_robot).
void validate_body(const proto::RobotFile& file, const MotorCatalog& motors);

// Pose of every body's inertial frame B in the robot frame for the link positions `q` (one per
// link, rad or m; spherical links take 0 = design orientation). Setup code (allocates).
std::vector<Eigen::Isometry3d> body_poses(const RobotModel& model, const std::vector<double>& q);

// Rotation of a proto Pose's rpy: Rz(yaw) * Ry(pitch) * Rx(roll), degrees in.
Eigen::Matrix3d rotation_from_rpy_deg(double roll_deg, double pitch_deg, double yaw_deg);

}  // namespace doppel::physics
