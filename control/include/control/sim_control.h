#pragma once
// What a user may ask of a running simulation (doppel-ctl, the viewer, a test) and what it reports:
// the contract between the HTTP API (control/) and the process that owns the world (gateway/), so
// that neither knows the other's insides. Requests are checked before anything is applied.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "control/world_model_settings.h"
#include "faults/fault.h"

namespace doppel::control {

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

// The latest still of a camera: a PNG, or an HTTP status and a message naming the problem.
struct CameraStill {
  int status = 200;  // 200, 404 no such camera, 503 nothing to render yet
  std::string error;
  std::string png;          // the encoded image (a replay's recorded still may be a JPEG: served as one)
  double sim_time_s = 0.0;  // simulation time of the scene it shows
};

// Where a replay (doppel-replay, docs/replay.md) is in its recording. Times are seconds of the
// recording's clock from its first message, so a pause during the recording replays as one.
struct ReplayStatus {
  double start_s = 0.0;     // the first world state
  double end_s = 0.0;       // the last message
  double position_s = 0.0;  // the moment state(), scene(), buses() and camera_still() show
  double speed = 1.0;       // recording seconds per wall-clock second while playing
  bool playing = false;     // false: paused, or stopped at the end
  std::vector<std::string> cameras;  // cameras whose stills were recorded
};

// A change of playback; a field left empty stays as it is. All fields are checked before any applies.
struct ReplayChange {
  std::optional<double> position_s;  // seek (scrub) to this moment, within [start_s, end_s]
  std::optional<double> speed;       // kMinReplaySpeed..kMaxReplaySpeed
  std::optional<bool> playing;
};
inline constexpr double kMinReplaySpeed = 0.1;
inline constexpr double kMaxReplaySpeed = 10.0;

// The GameController inside doppel (docs/gamecontroller.md): its game as the packets carry it,
// whether it sends, and what the robots answered. Teams are index 0 (A, cyan) and 1 (B, magenta).
struct GamePenalty {
  uint32_t player = 0;           // 1..11
  uint32_t penalty = 0;          // the protocol's penalty code (34 = HL pick-up or incapable)
  std::string reason;            // its name (pickup_or_incapable, ...)
  uint32_t seconds_left = 0;     // secsTillUnpenalised
};
struct GameTeam {
  uint32_t number = 0;
  uint32_t score = 0;
  std::vector<GamePenalty> penalties;  // the penalised players only
};
struct GameReturn {
  uint32_t team = 0, player = 0;  // as the robot said (team number, player 1..11)
  std::string message;            // alive, manual_penalise, manual_unpenalise
  uint64_t count = 0;             // return packets from it so far
  double age_s = 0.0;             // since the last one
};
struct GameStatus {
  bool on = false;               // doppel's own GameController runs (its sockets are open)
  bool sending = false;          // and sends (off: `game off`, or stepped aside)
  std::string stepped_aside;     // why it stopped by itself ("" = it did not)
  std::string destination;       // ADDRESS:PORT its packets go to
  std::string return_address;    // ADDRESS:PORT it receives return packets on
  std::string watch;             // ADDRESS:PORT it watches for another GameController; "" = none
  std::string watch_error;       // why there is no watch although one was asked for
  std::string state;             // initial, ready, set, playing, finished
  bool first_half = true;
  uint32_t kick_off_team = 0;    // a team number, or 255 (drop ball)
  std::string secondary_state;   // normal, timeout, direct_free_kick, ... (the protocol's STATE2_*)
  uint32_t secondary_team = 0;   // secondaryStateInfo[0]
  uint32_t secondary_mode = 0;   // secondaryStateInfo[1]
  uint32_t secs_remaining = 0;
  uint32_t packet_number = 0;
  uint64_t sent = 0;
  std::array<GameTeam, 2> teams{};
  std::vector<GameReturn> returns;
  uint64_t bad_returns = 0;      // wrong size, header, version or an unknown robot
  // Another GameController the watch saw (its last packet): where from, how many, its game.
  bool foreign = false;
  std::string foreign_from;
  uint64_t foreign_packets = 0;
  std::string foreign_state;
  std::array<uint32_t, 2> foreign_teams{}, foreign_scores{};
  double foreign_age_s = 0.0;
};

// One checked command to the GameController (control/http_api.cpp checks names and ranges).
struct GameCommand {
  std::string command;     // on, off, state, goal, score, kickoff, penalize, unpenalize, set_play, timeout, normal
  std::string state;       // state: initial (a new game), ready, set, playing, finished
  int team = -1;           // 0 (A) or 1 (B); kickoff: -1 = drop ball
  uint32_t player = 0;     // penalize, unpenalize: 1..11
  uint32_t seconds = 30;   // penalize: 0..255
  uint32_t penalty = 34;   // penalize: the protocol's code (checked against kGamePenalties)
  uint32_t score = 0;      // score: 0..255
  std::string set_play;    // direct_free_kick, indirect_free_kick, penalty_kick, corner_kick, goal_kick, throw_in
  uint32_t mode = 0;       // set_play: secondaryStateInfo[1], 0..255
};

// The penalty names the API takes and shows, with the Humanoid League's codes (packet.h).
struct GamePenaltyName {
  const char* name;
  uint32_t code;
};
inline constexpr std::array<GamePenaltyName, 7> kGamePenalties{{{"substitute", 14},
                                                                {"ball_manipulation", 30},
                                                                {"physical_contact", 31},
                                                                {"illegal_attack", 32},
                                                                {"illegal_defense", 33},
                                                                {"pickup_or_incapable", 34},
                                                                {"service", 35}}};

// The team-communication hub inside doppel (docs/teamcomm.md) and its registered robots.
struct TeamcommRobot {
  int team = 0;      // 0..255
  int player = 0;    // 0..255
  uint16_t port = 0; // where its software receives (and sends from)
};
struct TeamcommLink {
  TeamcommRobot from, to;
  uint64_t relayed = 0, dropped = 0, delayed = 0, queue_full = 0, send_errors = 0;
};
struct TeamcommStatus {
  std::string listen;         // ADDRESS:PORT the hub receives on
  std::string robot_address;  // where the robots' software runs
  double loss = 0.0, delay_ms = 0.0, jitter_ms = 0.0;
  uint64_t received = 0, unknown_sender = 0, oversized = 0;
  std::vector<TeamcommRobot> robots;
  std::vector<TeamcommLink> links;
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

// A robot's world-model sensor settings, or an HTTP status and a message naming the problem.
struct WorldModelAnswer {
  int status = 200;  // 200, 400 a bad setting (the message names the field), 404 no such robot or sensor
  std::string error;
  WorldModelSettings settings;
};

// Faults on demand (docs/faults.md): every fault of the run (ended ones too) at `sim_time_s`.
struct FaultEntry {
  faults::Fault fault;
  bool active = false;  // in force now
  bool ended = false;   // its end has passed (cleared, or its duration ran out)
};
struct FaultList {
  double sim_time_s = 0.0;
  std::vector<FaultEntry> faults;
};
struct FaultAnswer {
  int status = 200;  // 200, 400 a field (named in error), 404 no such robot / bus / device, 409 too many faults
  std::string error;
  uint32_t number = 0;  // the new fault's number
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
  // What the viewer draws: every visible shape (empty without a world). Published by the
  // simulation thread at most 30 times a second.
  virtual Scene scene() { return {}; }
  // Every bus' servo table (robot by robot, bus by bus).
  virtual std::vector<BusTable> buses() { return {}; }
  // The latest image of robot camera `name` (as RobotState::cameras names it), a few per second.
  virtual CameraStill camera_still(const std::string& name) { return {404, "no camera '" + name + "'", "", 0.0}; }
  // Robot `robot`'s world-model sensor (docs/multilevel.md): its settings, and a change of them
  // applied from its next message on (checked completely; a bad value is refused naming its field).
  virtual WorldModelAnswer world_model(std::size_t robot) {
    (void)robot;
    return {404, "no world-model sensor in this simulation (doppel --world-model)", {}};
  }
  virtual WorldModelAnswer set_world_model(std::size_t robot, const WorldModelSettings& settings) {
    (void)settings;
    return world_model(robot);
  }
  // A replay's playback (none for a live simulation: the API then answers 404).
  virtual std::optional<ReplayStatus> replay() { return std::nullopt; }
  // Applies a checked change (control/http_api.cpp checks the fields and ranges against replay()).
  virtual Outcome change_replay(const ReplayChange& change) {
    (void)change;
    return Outcome::fail(404, "this is not a replay");
  }
  // The bus analysis of a replay's recording as a JSON document, serialised by whoever made it (the
  // analyzer, docs/analyzer.md: control/ does not know its fields). None for a live simulation or a
  // recording without bus traffic: the API then answers 404 and the viewer shows no Bus panel.
  virtual std::optional<std::string> bus_analysis() { return std::nullopt; }
  // The GameController (none: /api/game answers 404, e.g. in a replay).
  virtual std::optional<GameStatus> game() { return std::nullopt; }
  // Applies a checked command; 409 with the game's reason when the game refuses it.
  virtual Outcome game_command(const GameCommand& command) {
    (void)command;
    return Outcome::fail(404, "no GameController here");
  }
  // The team-communication hub (none: /api/teamcomm answers 404; doppel --teamcomm starts one).
  virtual std::optional<TeamcommStatus> teamcomm() { return std::nullopt; }
  virtual Outcome teamcomm_add(const TeamcommRobot& robot) {
    (void)robot;
    return Outcome::fail(404, "no team-communication hub (doppel --teamcomm)");
  }
  // Faults on demand (none: /api/faults answers 404, e.g. in a replay). add_fault gets a spec that
  // passed faults::check(); the target (robot, bus, device) is checked here.
  virtual std::optional<FaultList> faults() { return std::nullopt; }
  virtual FaultAnswer add_fault(const faults::FaultSpec& spec) {
    (void)spec;
    return {404, "no faults here (a replay shows the recorded ones)", 0};
  }
  // Ends fault `number` now (404: no such fault); clear_faults ends every one.
  virtual Outcome clear_fault(uint32_t number) {
    (void)number;
    return Outcome::fail(404, "no faults here");
  }
  virtual Outcome clear_faults() { return Outcome::fail(404, "no faults here"); }
  virtual Outcome teamcomm_remove(int team, int player) {
    (void)team;
    (void)player;
    return Outcome::fail(404, "no team-communication hub (doppel --teamcomm)");
  }
};

}  // namespace doppel::control
