#include "gateway/options.h"

#include <CLI/CLI.hpp>

#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "base/command_line.h"
#include "eeprom_state.h"

namespace doppel::gateway {
namespace {

CLI::Validator not_empty(std::string what) {
  return CLI::Validator(
      [what](std::string& text) { return text.empty() ? what + " must not be empty" : std::string(); }, "");
}

template <typename T>
std::string shown(const T& value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// What --help shows after the option's name: its value's label and, when it has one, its default.
CLI::Option* label(CLI::Option* option, const std::string& value, const std::string& default_value = "") {
  return option->option_text(value + (default_value.empty() ? "" : "=" + default_value));
}

// One service's command-line options: declared into their own group of the parser (and so of
// --help) with their defaults taken from the service's struct in Options, then checked and turned
// into that struct's settings once parsed. Each group sees its own struct only. Members hold what
// a service reads as text first (e.g. "A,B").
class ServiceGroup {
 public:
  virtual ~ServiceGroup() = default;
  virtual void declare(CLI::App& app) = 0;
  // After parsing; throws std::invalid_argument naming the option.
  virtual void check(const CLI::App& app) { (void)app; }
};

// The robots and their buses.
class BusGroup final : public ServiceGroup {
 public:
  explicit BusGroup(BusOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Robots and their buses";
    label(app.add_option("--robot", options_.robots,
                         "Robot description: a shipped robot name (see --list-robots) or a protobuf text\n"
                         "file. Repeat to run several robots.")
              ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
              ->allow_extra_args(false)
              ->group(group),
          "NAME|FILE", "fumanoid-2011");
    label(app.add_option("--robots-dir", options_.robots_dir,
                         "Where robot names are looked up (default: the data/robots/ folder of the source tree,\n"
                         "or $DOPPEL_ROBOTS_DIR).")
              ->group(group),
          "DIR");
    label(app.add_option("--link-dir", options_.link_dir,
                         "Directory for the stable port links ($XDG_RUNTIME_DIR/doppel, or\n"
                         "/tmp/doppel-$USER without a private XDG_RUNTIME_DIR).\n"
                         "Robot 0, bus b:  DIR/ttyDXL<b>        (e.g. /tmp/doppel-$USER/ttyDXL0)\n"
                         "Robot r>0, bus b: DIR/robot<r>/ttyDXL<b>\n"
                         "Refused if it is a symlink, another user's, or writable by others.")
              ->check(not_empty("the directory"))
              ->group(group),
          "DIR", "$XDG_RUNTIME_DIR/doppel");
    app.add_flag("--allow-shared-link-dir", options_.allow_shared_link_dir, "Use such a link directory anyway, with a warning.")
        ->group(group);
    label(app.add_option_function<std::string>(
                 "--timing",
                 [this](const std::string& mode) {
                   options_.timing = mode == "wire" ? bus::TimingMode::kWire : bus::TimingMode::kFast;
                 },
                 "wire: statuses arrive when a real bus at the port's baud rate would deliver\n"
                 "them (wire time, firmware time, Return Delay Time). fast: statuses are written\n"
                 "as soon as they are computed.")
              ->check(CLI::IsMember({"wire", "fast"}))
              ->group(group),
          "wire|fast", options_.timing == bus::TimingMode::kWire ? "wire" : "fast");
    label(app.add_option("--processing-us", options_.processing_us,
                         "Firmware processing time before the Return Delay Time starts, in µs (as\n"
                         "measured on MX-64 servos).")
              ->transform(number_in<double>(0.0, 10000.0))
              ->group(group),
          "US", shown(options_.processing_us));
    label(app.add_option("--latency-timer", options_.latency_timer_ms,
                         "Model a USB serial adapter (FTDI/U2D2) whose latency timer is MS ms (1..255;\n"
                         "FTDI default 16). 0: no adapter model.")
              ->transform(number_in<uint32_t>(0, 255))
              ->group(group),
          "MS", shown(options_.latency_timer_ms));
    label(app.add_option("--rt-priority", options_.rt_priority,
                         "Run the bus I/O threads with SCHED_FIFO priority P (1..99; needs CAP_SYS_NICE\n"
                         "or root). 0: normal scheduling. Cuts the latency tail on a loaded machine.")
              ->transform(number_in<int>(0, 99))
              ->group(group),
          "P", shown(options_.rt_priority));
    app.add_flag("--list-robots", options_.list_robots, "Print the shipped robots and exit.")->group(group);
  }
  void check(const CLI::App&) override {
    if (options_.robots.empty()) options_.robots.emplace_back("fumanoid-2011");
  }

 private:
  BusOptions& options_;
};

// The physics world of the robots' bodies.
class WorldGroup final : public ServiceGroup {
 public:
  explicit WorldGroup(WorldOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "World";
    label(app.add_option_function<std::string>(
                 "--physics",
                 [this](const std::string& engine) {
                   options_.physics = engine == "none" ? std::nullopt : std::optional(physics::engine_from_name(engine));
                 },
                 "Physics engine for the robots' bodies. Robots whose file has no body, and every\n"
                 "robot with 'none', move kinematically: joints turn toward their goals at the\n"
                 "commanded speed, the IMU lies level, the feet carry the weight evenly.")
              ->check(CLI::IsMember({"ode", "bullet", "none"}))
              ->group(group),
          "ode|bullet|none", options_.physics ? std::string(physics::engine_name(*options_.physics)) : "none");
    label(app.add_option("--solver-iterations", options_.solver_iterations,
                         "Constraint solver sweeps per physics step (1..1000). Default: the largest a\n"
                         "robot file asks for (op3: 100, its light links carry a heavy trunk), else 10.")
              ->transform(number_in<int>(1, 1000))
              ->group(group),
          "N");
    app.add_flag_callback("--no-hold", [this] { options_.hold = false; },
                 "Release every robot at start. By default a robot is held in its initial pose, as\n"
                 "a handler holds a real robot while it powers up, until its driver has enabled\n"
                 "torque on all of its servos (each joint follows its servo from its Torque Enable\n"
                 "on), or 1 s after the first.")
        ->group(group);
    label(app.add_option("--session", options_.session,
                         "Session file (protobuf text, libs/proto/session.proto): cameras fixed in the field,\n"
                         "such as data/sessions/sideline-camera.textproto (a TV view from the touch line).\n"
                         "They stream like the robots' cameras, also with --physics none.")
              ->check(not_empty("the file name"))
              ->group(group),
          "FILE");
  }

 private:
  WorldOptions& options_;
};

// Persistent EEPROM (README "State").
class StateGroup final : public ServiceGroup {
 public:
  explicit StateGroup(StateOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "EEPROM state";
    label(app.add_option("--state-dir", options_.dir,
                         "Keep each robot's EEPROM areas (IDs, baud rates, Protocol Type, limits the\n"
                         "driver wrote) in DIR across runs, as real servos keep them ($XDG_STATE_HOME/\n"
                         "doppel, else ~/.local/state/doppel). A state file that is corrupt or belongs\n"
                         "to another robot layout stops doppel.")
              ->check(not_empty("the directory"))
              ->group(group),
          "DIR", "$XDG_STATE_HOME/doppel");
    app.add_flag("--fresh", options_.fresh, "Start from the robot files' values and overwrite the saved state.")->group(group);
  }
  void check(const CLI::App&) override {
    if (options_.dir.empty()) options_.dir = default_state_dir();
  }

 private:
  StateOptions& options_;
};

// The cameras over iceoryx.
class CameraGroup final : public ServiceGroup {
 public:
  explicit CameraGroup(CameraOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Cameras";
    app.add_flag_callback("--no-camera", [this] { options_.enabled = false; },
                 "Stream no camera. By default every camera of a simulated robot's description\n"
                 "(the default robot's head camera: 640x480 YUYV, 20 fps, wide lens) streams\n"
                 "through iceoryx shared memory; see doppel-camera.")
        ->group(group);
    app.add_flag("--external-roudi", options_.external_roudi,
                 "Use an iceoryx RouDi that is already running (iox-roudi) and fail without one.\n"
                 "By default doppel uses a running RouDi if there is one and otherwise runs RouDi\n"
                 "inside itself.")
        ->group(group);
    app.add_flag("--verbose", options_.verbose, "Also print iceoryx's own log lines (warnings and info).")->group(group);
  }

 private:
  CameraOptions& options_;
};

// The web viewer and simulation control over HTTP.
class ViewerGroup final : public ServiceGroup {
 public:
  explicit ViewerGroup(ViewerOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Viewer and simulation control";
    label(app.add_option("--viewer", options_.port,
                         "Serve the web viewer (http://127.0.0.1:PORT/: 3D view, servo tables, controls)\n"
                         "and simulation control (JSON API for doppel-ctl: state, pause, resume, step,\n"
                         "reset, place, push, ball) on PORT (0 = any free port, printed at start). If\n"
                         "the default port is taken doppel runs without it and says so.")
              ->transform(number_in<uint16_t>(0, 65535))
              ->group(group),
          "PORT", "7580");
    label(app.add_option("--viewer-address", options_.address,
                         "Address to serve it on (127.0.0.1: this machine only). Anyone who can reach it\n"
                         "can move the robots: name another address only on a network you trust.")
              ->check(not_empty("the address"))
              ->group(group),
          "ADDR", options_.address);
    label(app.add_option("--viewer-dir", options_.dir,
                         "The viewer's page (index.html, viewer.js) from DIR instead of the source tree's\n"
                         "web/viewer/ (or $DOPPEL_VIEWER_DIR). three.js comes from Debian's libjs-three.")
              ->check(not_empty("the folder"))
              ->group(group),
          "DIR");
    app.add_flag_callback("--no-viewer", [this] { options_.enabled = false; }, "Serve neither the viewer nor simulation control.")->group(group);
    app.add_flag_callback("--no-token", [this] { options_.token = false; },
                 "Let any local user and program use the control API and the TCP handshake\n"
                 "without the run's access token (the old behaviour; only for a machine of your\n"
                 "own with no other users: docs/security.md). Host and Origin are checked still.")
        ->group(group);
  }

 private:
  ViewerOptions& options_;
};

// The session handshake (docs/handshake.md).
class HandshakeGroup final : public ServiceGroup {
 public:
  explicit HandshakeGroup(HandshakeOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Session handshake";
    label(app.add_option("--handshake-socket", options_.socket,
                         "Serve the session handshake (docs/handshake.md: control software asks for\n"
                         "robots, their cameras and sensors, and gets their links) on this Unix socket.")
              ->check(not_empty("the socket path"))
              ->group(group),
          "PATH", "LINK_DIR/handshake.sock");
    label(app.add_option("--handshake-port", options_.port,
                         "Also serve it over TCP on PORT (the default used only if free; 0 = any free\n"
                         "port, printed at start).")
              ->transform(number_in<uint16_t>(0, 65535))
              ->group(group),
          "PORT", "7590");
    label(app.add_option("--handshake-address", options_.address,
                         "Address of the TCP handshake (127.0.0.1: this machine only). Anyone who can\n"
                         "reach it can add and remove robots: name another address only on a network\n"
                         "you trust.")
              ->check(not_empty("the address"))
              ->group(group),
          "ADDR", options_.address);
    app.add_flag_callback("--no-handshake-tcp", [this] { options_.tcp = false; }, "Serve the handshake on the Unix socket only.")->group(group);
    app.add_flag_callback("--no-handshake", [this] { options_.enabled = false; }, "Serve no handshake.")->group(group);
  }

 private:
  HandshakeOptions& options_;
};

// The recorder (docs/recording.md).
class RecordGroup final : public ServiceGroup {
 public:
  explicit RecordGroup(RecordOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Recording";
    label(app.add_option("--record", options_.path,
                         "Record the run to FILE (MCAP, docs/recording.md): every bus transaction with its\n"
                         "bytes and times, the world state at 100 Hz, servo tables, the scene. Read it\n"
                         "with doppel-bus report, doppel-replay or Foxglove.")
              ->check(not_empty("the file name"))
              ->group(group),
          "FILE.mcap");
    label(app.add_option("--record-cameras", options_.camera_hz,
                         "Also record each camera's still (PNG) HZ times a second (0.1..30).")
              ->transform(number_in<double>(0.1, 30.0))
              ->group(group),
          "HZ");
    label(app.add_option("--record-compression", options_.compression, "Chunk compression of the recording.")
              ->check(CLI::IsMember({"zstd", "lz4", "none"}))
              ->group(group),
          "zstd|lz4|none", options_.compression);
  }
  void check(const CLI::App&) override {
    if (options_.camera_hz > 0.0 && options_.path.empty()) {
      throw std::invalid_argument("--record-cameras needs --record FILE.mcap (see --help)");
    }
  }

 private:
  RecordOptions& options_;
};

// The world-model sensor and the sensor levels on the truth transport (docs/multilevel.md).
class TruthGroup final : public ServiceGroup {
 public:
  explicit TruthGroup(TruthOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "World model and sensor levels";
    contract::WorldModelSettings& world_model = options_.world_model_settings;
    app.add_flag("--world-model", options_.world_model,
                 "Give every simulated robot a world-model sensor (docs/multilevel.md): its own\n"
                 "pose, the balls, goal posts, side poles, field landmarks and the other robots,\n"
                 "in the field frame and relative to the robot, 30 times a second of simulation\n"
                 "time, published over iceoryx (\"DoppelTruth\", \"robot<N>\", \"world_model\") and\n"
                 "UDP; read them with doppel-truth. Noise, dropout and latency: doppel-ctl\n"
                 "world-model.")
        ->group(group);
    implying_.push_back(label(app.add_option("--world-model-rate", world_model.rate_hz,
                                             "Messages per second of simulation time (0.1..1000).")
                                  ->transform(number_in<double>(0.1, 1000.0))
                                  ->group(group),
                              "HZ", shown(world_model.rate_hz)));
    implying_.push_back(label(app.add_option("--world-model-fov", world_model.fov_deg,
                                             "Horizontal field of view about the head camera's optical axis (the heading\n"
                                             "without a camera), 1..179; 0: all around.")
                                  ->transform(number_in<double>(1.0, 179.0))
                                  ->group(group),
                              "DEG", shown(world_model.fov_deg)));
    implying_.push_back(label(app.add_option("--world-model-range", world_model.max_range_m,
                                             "Objects farther than M metres are not seen (0: no limit).")
                                  ->transform(number_in<double>(0.0, 100.0))
                                  ->group(group),
                              "M", shown(world_model.max_range_m)));
    implying_.push_back(app.add_flag("--world-model-nearest-ball", world_model.nearest_ball_only,
                                     "Of several balls (a session's extra balls), report only the nearest seen.")
                            ->group(group));
    label(app.add_option("--truth-udp-port", options_.udp_port, "Robot N's world model goes to UDP port BASE+N.")
              ->transform(number_in<uint16_t>(1, 65471))
              ->group(group),
          "BASE", shown(options_.udp_port));
    label(app.add_option("--truth-udp-address", options_.udp_address,
                         "...on this IPv4 address (127.0.0.1: this machine only; name another address only\n"
                         "for control software on another machine).")
              ->check(CLI::ValidIPV4)
              ->group(group),
          "ADDR", options_.udp_address);
    app.add_flag_callback("--no-truth-iceoryx", [this] { options_.iceoryx = false; },
                 "Publish the world model over UDP only (no iceoryx RouDi needed).")
        ->group(group);
    label(app.add_option("--sensor-levels", options_.sensor_levels_hz,
                         "Publish every servo's, IMU's and foot board's registers decoded to SI units\n"
                         "beside the simulation's true values, HZ times per simulated second\n"
                         "(0.1..1000), as topic sensor_levels on the same transport (docs/multilevel.md).")
              ->transform(number_in<double>(0.1, 1000.0))
              ->group(group),
          "HZ");
  }
  void check(const CLI::App&) override {
    for (const CLI::Option* option : implying_) {
      if (option->count() > 0) options_.world_model = true;
    }
  }

 private:
  TruthOptions& options_;
  std::vector<CLI::Option*> implying_;  // the options that imply --world-model
};

// The GameController inside doppel (docs/gamecontroller.md).
class GameControllerGroup final : public ServiceGroup {
 public:
  explicit GameControllerGroup(GameControllerOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "GameController";
    label(app.add_option("--gamecontroller", on_off_,
                         "Run a RoboCup GameController (Humanoid League protocol, struct version 12;\n"
                         "docs/gamecontroller.md) inside doppel, driven from doppel-ctl game and the\n"
                         "viewer. Off by default: a robot's software behaves differently once it hears\n"
                         "a GameController. doppel-ctl game on starts it later.")
              ->expected(0, 1)
              ->group(group),
          "[on|off]", options_.enabled ? "on" : "off");
    label(app.add_option("--gc-teams", teams_, "Team numbers of team A (cyan, kicks off first) and B.")
              ->check(not_empty("the team numbers"))
              ->group(group),
          "A,B", shown(options_.team_a) + "," + shown(options_.team_b));
    label(app.add_option("--gc-players", options_.players, "Players per team in the packets.")
              ->transform(number_in<int>(1, 11))
              ->group(group),
          "N", shown(options_.players));
    label(app.add_option("--gc-destination", options_.destination,
                         "Where the game packets go (127.0.0.1: this machine only). A broadcast address\n"
                         "(x.x.x.255) sends to the LAN: only if you name it.")
              ->check(not_empty("the address"))
              ->group(group),
          "ADDRESS:PORT", options_.destination);
    label(app.add_option("--gc-return", options_.return_to, "Where return packets are received.")
              ->check(not_empty("the address"))
              ->group(group),
          "ADDRESS:PORT", options_.return_to);
    label(app.add_option("--gc-watch", options_.watch,
                         "Watch for another GameController's packets and stop sending when one appears\n"
                         "(the default: broadcasts only, never the unicast packets meant for the robots;\n"
                         "shares the port with SO_REUSEADDR, so a robot's software binding 3838 needs\n"
                         "SO_REUSEADDR too, or use off).")
              ->check(not_empty("the address"))
              ->group(group),
          "ADDRESS:PORT|off", options_.watch);
  }
  void check(const CLI::App& app) override {
    if (app.count("--gamecontroller") > 0) {
      if (on_off_ != "" && on_off_ != "on" && on_off_ != "off") {
        throw std::invalid_argument("--gamecontroller '" + on_off_ + "': expected on or off (see --help)");
      }
      options_.enabled = on_off_ != "off";
    }
    if (teams_.empty()) return;
    const auto comma = teams_.find(',');
    const auto team = [this](const std::string& part) {
      if (part.empty() || part.size() > 3 || part.find_first_not_of("0123456789") != std::string::npos || std::stoi(part) > 255) {
        throw std::invalid_argument("--gc-teams '" + teams_ + "': '" + part + "' is not a team number 0..255 (see --help)");
      }
      return std::stoi(part);
    };
    if (comma == std::string::npos) throw std::invalid_argument("--gc-teams '" + teams_ + "': expected A,B (see --help)");
    options_.team_a = team(teams_.substr(0, comma));
    options_.team_b = team(teams_.substr(comma + 1));
    if (options_.team_a == options_.team_b) {
      throw std::invalid_argument("--gc-teams '" + teams_ + "': the two teams need different numbers (see --help)");
    }
  }

 private:
  GameControllerOptions& options_;
  std::string on_off_;  // --gamecontroller's value: "", on or off
  std::string teams_;   // --gc-teams A,B
};

// The team-communication hub (docs/teamcomm.md).
class TeamcommGroup final : public ServiceGroup {
 public:
  explicit TeamcommGroup(TeamcommOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Team communication";
    label(app.add_option("--teamcomm", options_.hub,
                         "Relay the robots' team messages (UDP) between their software on this machine\n"
                         "(docs/teamcomm.md), listening on ADDRESS:PORT (default address 127.0.0.1; port\n"
                         "0: any free port, printed at start).")
              ->check(not_empty("the address"))
              ->group(group),
          "[ADDRESS:]PORT");
    label(app.add_option("--teamcomm-robot", options_.robots,
                         "A robot's software that receives (and sends from) PORT; repeat. Robots can also\n"
                         "register while doppel runs (doppel-ctl teamcomm add).")
              ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
              ->group(group),
          "TEAM:PLAYER:PORT");
    label(app.add_option("--teamcomm-robot-address", options_.robot_address,
                         "The address the robots' software runs on.")
              ->check(not_empty("the address"))
              ->group(group),
          "ADDR", options_.robot_address);
    // The WiFi model of every link, as doppel-teamcomm's options of the same names.
    const char* link = "The WiFi model of every link, as doppel-teamcomm's option of the same name.";
    teamcomm::LinkModelConfig& model = options_.link;
    label(app.add_option("--teamcomm-loss", model.loss_probability, link)->transform(number_in<double>(0.0, 1.0))->group(group),
          "P", shown(model.loss_probability));
    label(app.add_option("--teamcomm-delay-ms", delay_ms_, link)->transform(number_in<double>(0.0, 60000.0))->group(group),
          "D", shown(delay_ms_));
    label(app.add_option("--teamcomm-jitter-ms", jitter_ms_, link)->transform(number_in<double>(0.0, 60000.0))->group(group),
          "J", shown(jitter_ms_));
    label(app.add_option("--teamcomm-jitter", jitter_, link)->check(CLI::IsMember({"uniform", "normal"}))->group(group),
          "uniform|normal", jitter_);
    label(app.add_option("--teamcomm-burst-enter", model.p_good_to_bad, link)->transform(number_in<double>(0.0, 1.0))->group(group),
          "P", shown(model.p_good_to_bad));
    label(app.add_option("--teamcomm-burst-leave", model.p_bad_to_good, link)->transform(number_in<double>(0.0, 1.0))->group(group),
          "P", shown(model.p_bad_to_good));
    label(app.add_option("--teamcomm-burst-loss", model.loss_in_bad, link)->transform(number_in<double>(0.0, 1.0))->group(group),
          "P", shown(model.loss_in_bad));
    label(app.add_option("--teamcomm-seed", options_.seed, link)->group(group), "S", shown(options_.seed));
  }
  void check(const CLI::App& app) override {
    options_.link.delay_ns = static_cast<int64_t>(delay_ms_ * 1e6);
    options_.link.jitter_ns = static_cast<int64_t>(jitter_ms_ * 1e6);
    options_.link.jitter = jitter_ == "normal" ? teamcomm::Jitter::kHalfNormal : teamcomm::Jitter::kUniform;
    options_.link.burst = options_.link.p_good_to_bad > 0.0;
    if (!options_.hub.empty()) return;
    for (const char* name : {"--teamcomm-robot", "--teamcomm-loss", "--teamcomm-delay-ms", "--teamcomm-jitter-ms",
                             "--teamcomm-burst-enter"}) {
      if (app.count(name) > 0) throw std::invalid_argument(std::string(name) + " needs --teamcomm [ADDRESS:]PORT (see --help)");
    }
  }

 private:
  TeamcommOptions& options_;
  double delay_ms_ = 0.0, jitter_ms_ = 0.0;
  std::string jitter_ = "uniform";
};

// Lockstep time (docs/lockstep.md).
class LockstepGroup final : public ServiceGroup {
 public:
  explicit LockstepGroup(LockstepOptions& options) : options_(options) {}
  void declare(CLI::App& app) override {
    const char* group = "Lockstep";
    app.add_flag("--lockstep", options_.enabled,
                 "Simulation time instead of the wall clock (docs/lockstep.md): time advances only\n"
                 "while every thread of a controller started with `doppel-run --lockstep` waits,\n"
                 "as fast as the machine can. Implies --timing wire on its own clock.")
        ->group(group);
    app.add_flag("--hashes", options_.hashes,
                 "With --lockstep: print `hash SECOND HEX` for every simulated second (bus bytes in\n"
                 "and out with their times, world state): equal runs, equal lines.")
        ->group(group);
    label(app.add_option("--hashes-file", options_.hashes_file, "The same lines to FILE instead of standard output.")
              ->check(not_empty("the file name"))
              ->group(group),
          "FILE");
    label(app.add_option("--lockstep-watchdog", options_.watchdog_s,
                         "Wall seconds a controller thread may run without a wait doppel sees before it\n"
                         "is reported.")
              ->transform(number_in<double>(0.1, 3600.0))
              ->group(group),
          "S", shown(options_.watchdog_s));
    label(app.add_option("--lockstep-epoch", options_.epoch_s,
                         "CLOCK_REALTIME at simulation time 0, Unix seconds (default: when doppel starts).")
              ->transform(number_in<double>(0.0, 1e11))
              ->group(group),
          "S");
  }
  void check(const CLI::App&) override {
    if ((options_.hashes || !options_.hashes_file.empty() || options_.epoch_s) && !options_.enabled) {
      throw std::invalid_argument("--hashes, --hashes-file and --lockstep-epoch need --lockstep (see --help)");
    }
  }

 private:
  LockstepOptions& options_;
};

// Every service's options, in the order --help shows them, each bound to its struct in `options`.
std::vector<std::unique_ptr<ServiceGroup>> services(Options& options) {
  std::vector<std::unique_ptr<ServiceGroup>> out;
  out.push_back(std::make_unique<BusGroup>(options.buses));
  out.push_back(std::make_unique<WorldGroup>(options.world));
  out.push_back(std::make_unique<StateGroup>(options.state));
  out.push_back(std::make_unique<CameraGroup>(options.cameras));
  out.push_back(std::make_unique<ViewerGroup>(options.viewer));
  out.push_back(std::make_unique<HandshakeGroup>(options.handshake));
  out.push_back(std::make_unique<RecordGroup>(options.record));
  out.push_back(std::make_unique<TruthGroup>(options.truth));
  out.push_back(std::make_unique<GameControllerGroup>(options.gamecontroller));
  out.push_back(std::make_unique<TeamcommGroup>(options.teamcomm));
  out.push_back(std::make_unique<LockstepGroup>(options.lockstep));
  return out;
}

// The options a command line starts from (an in-process Options{} differs: no handshake, no state).
Options command_line_defaults() {
  Options options;
  options.handshake.enabled = true;
  return options;
}

// The parser of every service's options, each filling its struct in `options`.
std::unique_ptr<CLI::App> make_parser(Options& options, const std::vector<std::unique_ptr<ServiceGroup>>& declared) {
  auto app = std::make_unique<CLI::App>(
      "Emulates the Dynamixel buses of one or more robots on pseudo-terminals, so that unmodified\n"
      "servo-bus drivers can talk to a simulated robot. Runs until SIGINT or SIGTERM.\n"
      "Also: doppel scenario run FILE [--seed N] [--param NAME=VALUE]...   (docs/scenarios.md)",
      "doppel");
  app->set_help_flag();  // --help only sets Options::help; main prints usage()
  app->option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app->get_formatter()->column_width(25);
  app->footer(
      "The port baud rate set by the driver (termios, including BOTHER rates) must match the devices'\n"
      "Baud Rate registers, as on real hardware; the robot file sets them (fumanoid-2011: 1 Mbps).");
  app->add_flag("-h,--help", options.help, "Print this text and exit.");
  for (const auto& service : declared) service->declare(*app);
  return app;
}

}  // namespace

std::string usage() {
  Options options = command_line_defaults();
  const auto declared = services(options);
  return make_parser(options, declared)->help();
}

Options parse_options(int argc, const char* const* argv) {
  Options options = command_line_defaults();
  const auto declared = services(options);
  const std::unique_ptr<CLI::App> app = make_parser(options, declared);
  try {
    app->parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    throw std::invalid_argument(std::string(e.what()) + " (see --help)");
  }
  for (int i = 0; i < argc; ++i) {
    options.command_line += (i > 0 ? " " : "") + std::string(argv[i]);
  }
  for (const auto& service : declared) service->check(*app);
  return options;
}

}  // namespace doppel::gateway
