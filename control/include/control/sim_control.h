#pragma once
// What a user may ask of a running simulation (doppel-ctl, the viewer, a test) and what it reports:
// the contract between the HTTP API (control/) and the process that owns the world (gateway/), so
// that neither knows the other's insides. Requests are checked before anything is applied.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace doppel::control {

struct JointState {
  std::string name;         // the figure's link name
  double position_rad = 0.0;  // the link's angle (m for a prismatic link), 0 at the design pose
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
};

struct SimState {
  double sim_time_s = 0.0;
  bool paused = false;
  uint64_t steps_left = 0;             // of a `step` request still running
  std::vector<RobotState> robots;
  std::optional<std::vector<double>> ball_m;  // x, y, z; none without a world
  double carpet_half_length_m = 0.0;   // where place and ball may put things: |x| <= this
  double carpet_half_width_m = 0.0;    // |y| <= this
};

// A robot counts as fallen when its robot frame leans more than this from upright (trunk on the
// carpet is 90 degrees; a walking robot leans far less than 45).
inline constexpr double kFallenTiltRad = 0.7853981633974483;  // 45 degrees

// The answer to a request: `ok`, or an HTTP status and a message naming the problem.
struct Outcome {
  int status = 200;  // 200 done, 404 no such robot, 409 not possible now, 503 the simulation did not answer
  std::string error;
  static Outcome done() { return {}; }
  static Outcome fail(int status, std::string error) { return {status, std::move(error)}; }
};

class SimControl {
 public:
  virtual ~SimControl() = default;
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
};

}  // namespace doppel::control
