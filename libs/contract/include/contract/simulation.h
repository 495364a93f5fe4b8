#pragma once
// What a user may ask of a running simulation (doppel-ctl, the viewer, a test) and what it reports:
// the contract between the transport (the HTTP API in control/) and the process that owns the world
// (gateway/, or a replay), so that neither knows the other's insides. The simulation facet is here;
// host.h names the others a host may offer.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "contract/error.h"

namespace doppel::contract {


struct JointState {
  std::string name;         // the figure's link name
  double position_rad = 0.0;  // the link's angle (m for a prismatic link), 0 at the design pose
};

// What an IMU of the robot last measured (the physics world's readout the device reports).
struct ImuReading {
  std::string name;  // the robot file's device name
  uint32_t bus = 0;
  uint8_t id = 0;
  double roll_rad = 0.0, pitch_rad = 0.0;  // + pitch = nose down
  std::array<double, 3> gyro_rad_s{};     // angular velocity in the sensor frame: x, y, z
};

// What a foot board's four load cells last measured, N.
struct FootReading {
  std::string name;
  uint32_t bus = 0;
  uint8_t id = 0;
  std::array<double, 4> force_n{};  // front-left, front-right, back-left, back-right
};

// A camera of the robot (a figure camera mount) where it is now, and its field of view as the rays
// through its image's four corners (camera frame: x right, y down, z forward; unit length).
struct CameraView {
  std::string name;  // the name it streams under
  std::array<double, 3> position{};                      // field frame, m
  std::array<double, 4> quaternion{0.0, 0.0, 0.0, 1.0};  // camera frame orientation: x, y, z, w
  std::array<std::array<double, 3>, 4> corner_rays{};    // top-left, top-right, bottom-right, bottom-left
};

struct RobotState {
  std::string name;        // the robot file's name; robots may share one, so requests also take an index
  bool simulated = false;  // has a body in the world (otherwise its joints move kinematically)
  // Robot frame in the field frame (x towards the yellow goal, origin on the centre spot).
  double x_m = 0.0, y_m = 0.0, z_m = 0.0, yaw_rad = 0.0;
  double tilt_rad = 0.0;   // robot frame's z axis against the vertical
  bool fallen = false;     // tilt beyond kFallenTiltRad
  bool held = false;       // the handler still holds it (no Torque Enable yet)
  std::vector<JointState> joints;
  std::vector<ImuReading> imus;     // in file order (bus by bus)
  std::vector<FootReading> feet;    // in file order
  std::vector<CameraView> cameras;  // in file order
};

struct SimState {
  double sim_time_s = 0.0;
  bool paused = false;
  uint64_t steps_left = 0;             // of a `step` request still running
  uint64_t missed_ticks = 0;           // 1 ms simulation ticks the simulation thread was late for, since start
  std::vector<RobotState> robots;
  std::optional<std::vector<double>> ball_m;  // x, y, z; none without a world
  double carpet_half_length_m = 0.0;   // where place and ball may put things: |x| <= this
  double carpet_half_width_m = 0.0;    // |y| <= this
};

// One visible shape of the world (physics::VisualShape as the viewer draws it). Field frame, m.
struct SceneShape {
  const char* type = "box";   // box (size = full extents), sphere (size[0] = radius), cylinder and capsule
                              // (size[0] = radius, size[1] = length along the shape's z), ring (outer
                              // radius, inner radius, thickness; flat in the shape's xy plane)
  const char* kind = "other";  // carpet, line, goal_post, goal_bar, goal_net, ball, side_pole, robot, team_marker, other
  uint16_t object_id = 0;      // which robot / goal / pole it belongs to (robot r: kFirstRobotObjectId + r)
  std::array<double, 3> position{};                  // shape frame origin
  std::array<double, 4> quaternion{0.0, 0.0, 0.0, 1.0};  // shape frame orientation: x, y, z, w
  std::array<double, 3> size{};
  std::array<uint8_t, 3> colour{};  // r, g, b
  // convex (a URDF mesh's hull): its vertices (x, y, z, ... in the shape frame) and triangles
  // (three vertex indices each, counter-clockwise seen from outside); empty for the other types
  std::vector<double> vertices;
  std::vector<unsigned> triangles;
};

struct Scene {
  double sim_time_s = 0.0;  // simulation time the poses belong to
  std::vector<SceneShape> shapes;
};

// One servo's registers as its bus thread last published them (every 100 ms): raw register values
// in the model's units (the e-Manual's), as the thesis' servo table showed them.
struct ServoRow {
  uint8_t id = 0;
  std::string name;   // the robot file's name for it
  std::string model;  // registry model name
  bool torque = false;
  int64_t goal_position = 0, present_position = 0;
  int64_t present_speed = 0;  // Present Speed (P1) / Present Velocity (P2)
  int64_t present_load = 0;   // Present Load (P1, and P2 models without current) / Present Current
  int64_t temperature = 0;    // Present Temperature, deg C
  int64_t voltage = 0;        // Present (Input) Voltage, 0.1 V
  int64_t error = -1;         // Hardware Error Status (Protocol 2.0); -1: the model has no such register (P1)
};

// A bus' counters since doppel started (bus::BusDiagnostics, read lock-free when asked).
struct BusCounters {
  uint64_t packets = 0;          // instruction packets framed (good or bad checksum)
  uint64_t bad_checksums = 0;    // of those, with a wrong checksum
  uint64_t replies = 0;          // instructions that got a status packet
  uint64_t collisions = 0;       // replies that collided on the wire (several devices answered at once)
  uint64_t dropped_replies = 0;  // replies dropped because the client was not reading
  uint64_t timeouts = 0;         // partial packets dropped by the inter-byte timeout
  uint64_t late_deliveries = 0;  // status packets written later than the bus' late threshold
  int64_t max_lateness_ns = 0;   // worst (written - due) of a status packet
  uint64_t bytes_in = 0, bytes_out = 0;
  bool connected = false;        // a client has the port open
};

struct BusTable {
  std::size_t robot = 0;
  std::string robot_name;
  std::size_t bus = 0;
  std::string link;        // the bus' pseudo-terminal link
  std::vector<ServoRow> servos;
  BusCounters counters;
};

// The latest still of a camera.
struct CameraStill {
  std::string png;          // the encoded image (a replay's recorded still may be a JPEG: served as one)
  double sim_time_s = 0.0;  // simulation time of the scene it shows
};

// A robot counts as fallen when its robot frame leans more than this from upright (trunk on the
// carpet is 90 degrees; a walking robot leans far less than 45).
inline constexpr double kFallenTiltRad = 0.7853981633974483;  // 45 degrees

// Every state a simulation publishes, in order, for one reader that must not miss any (the
// recorder), however late its thread runs: the simulation thread queues each state, and only a
// reader that falls the whole queue behind loses states, which lost() counts.
class StateQueue {
 public:
  virtual ~StateQueue() = default;
  // The reader's thread only: the oldest state not yet read; false when none is waiting.
  virtual bool pop(SimState& out) = 0;
  // States the simulation could not queue because the reader was that far behind. Any thread.
  virtual uint64_t lost() const = 0;
};

// The simulation facet, which every host offers: its state, what the viewer draws, and the
// requests that drive it. Requests are checked by the asker's layer before they get here (robot
// indices, ranges, the carpet); what only the host knows is checked here.
class Simulation {
 public:
  virtual ~Simulation() = default;
  virtual SimState state() = 0;
  // The world freezes: no physics step, the bus keeps answering with the frozen values, the IMU
  // sample counters and Realtime Tick stop. resume() lets it run again.
  virtual Outcome pause() = 0;
  virtual Outcome resume() = 0;
  // While paused: runs `steps` simulation steps (1 ms each) at real-time pace, then stays paused.
  // Returns once they ran.
  virtual Outcome step(uint32_t steps) = 0;
  // World and servos to their power-on state (robots where they started, held; servo RAM as at
  // power-on; the ball on its spot). Simulation time runs on.
  virtual Outcome reset() = 0;
  // Robot `robot` (index into state().robots) in its initial pose at (x, y), heading yaw, at rest.
  virtual Outcome place(std::size_t robot, double x_m, double y_m, double yaw_rad) = 0;
  // A force on the robot's trunk (field frame, N) for `steps` steps.
  virtual Outcome push(std::size_t robot, double fx_n, double fy_n, double fz_n, uint32_t steps) = 0;
  // The ball at rest at (x, y) on the carpet.
  virtual Outcome ball(double x_m, double y_m) = 0;
  // What the viewer draws: every visible shape (empty without a world). Published by the
  // simulation thread at most 30 times a second.
  virtual Scene scene() = 0;
  // Every bus' servo table (robot by robot, bus by bus).
  virtual std::vector<BusTable> buses() = 0;
  // The latest image of robot camera `name` (as RobotState::cameras names it), a few per second:
  // kNotFound for no such camera, kUnavailable while there is nothing to show yet.
  virtual Result<CameraStill> camera_still(const std::string& name) = 0;
};

}  // namespace doppel::contract
