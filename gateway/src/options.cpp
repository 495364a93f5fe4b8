#include "gateway/options.h"

#include <CLI/CLI.hpp>

#include <optional>
#include <stdexcept>

#include "base/command_line.h"
#include "eeprom_state.h"

namespace doppel::gateway {
namespace {

CLI::Validator not_empty(std::string what) {
  return CLI::Validator(
      [what](std::string& text) { return text.empty() ? what + " must not be empty" : std::string(); }, "");
}

}  // namespace

std::string usage() {
  return R"(Usage: doppel [OPTIONS]
       doppel scenario run FILE [--seed N] [--param NAME=VALUE]...   (docs/scenarios.md)

Emulates the Dynamixel buses of one or more robots on pseudo-terminals, so that unmodified
servo-bus drivers can talk to a simulated robot. Runs until SIGINT or SIGTERM.

Options:
  --robot NAME|FILE      Robot description: a shipped robot name (see --list-robots) or a
                         protobuf text file. Repeat to run several robots. Default: fumanoid-2011.
  --link-dir DIR         Directory for the stable port links. Default: $XDG_RUNTIME_DIR/doppel,
                         or /tmp/doppel-$USER without a private XDG_RUNTIME_DIR.
                         Robot 0, bus b:  DIR/ttyDXL<b>        (e.g. /tmp/doppel-$USER/ttyDXL0)
                         Robot r>0, bus b: DIR/robot<r>/ttyDXL<b>
                         Refused if it is a symlink, another user's, or writable by others.
  --allow-shared-link-dir
                         Use such a link directory anyway, with a warning.
  --timing wire|fast     wire (default): statuses arrive when a real bus at the port's baud rate
                         would deliver them (wire time, firmware time, Return Delay Time).
                         fast: statuses are written as soon as they are computed.
  --processing-us US     Firmware processing time before the Return Delay Time starts, in µs
                         (default 50, as measured on MX-64 servos).
  --latency-timer MS     Model a USB serial adapter (FTDI/U2D2) whose latency timer is MS ms
                         (1..255; FTDI default 16). Default 0: no adapter model.
  --physics ode|bullet|none
                         Physics engine for the robots' bodies (default ode). Robots whose file has
                         no body, and every robot with 'none', move kinematically: joints turn toward
                         their goals at the commanded speed, the IMU lies level, the feet carry the
                         weight evenly.
  --solver-iterations N  Constraint solver sweeps per physics step (1..1000). Default: the largest
                         a robot file asks for (op3: 100, its light links carry a heavy trunk),
                         else 10.
  --no-hold              Release every robot at start. By default a robot is held in its initial
                         pose, as a handler holds a real robot while it powers up, until its
                         driver has enabled torque on all of its servos (each joint follows its
                         servo from its Torque Enable on), or 1 s after the first.
  --session FILE         Session file (protobuf text, proto/session.proto): cameras fixed in the
                         field, such as sessions/sideline-camera.textproto (a TV view from the touch
                         line). They stream like the robots' cameras, also with --physics none.
  --no-camera            Stream no camera. By default every camera of a simulated robot's description
                         (the default robot's head camera: 640x480 YUYV, 20 fps, wide lens) streams
                         through iceoryx shared memory; see doppel-camera.
  --external-roudi       Use an iceoryx RouDi that is already running (iox-roudi) and fail without one.
                         By default doppel uses a running RouDi if there is one and otherwise runs
                         RouDi inside itself.
  --verbose              Also print iceoryx's own log lines (warnings and info).
  --rt-priority P        Run the bus I/O threads with SCHED_FIFO priority P (1..99; needs
                         CAP_SYS_NICE or root). Default 0: normal scheduling. Cuts the latency
                         tail on a loaded machine.
  --robots-dir DIR       Where robot names are looked up (default: the robots/ folder of the source tree,
                         or $DOPPEL_ROBOTS_DIR).
  --state-dir DIR        Keep each robot's EEPROM areas (IDs, baud rates, Protocol Type, limits the
                         driver wrote) in DIR across runs, as real servos keep them. Default:
                         $XDG_STATE_HOME/doppel, else ~/.local/state/doppel. A state file that is
                         corrupt or belongs to another robot layout stops doppel.
  --fresh                Start from the robot files' values and overwrite the saved state.
  --viewer PORT          Serve the web viewer (http://127.0.0.1:PORT/: 3D view, servo tables, controls)
                         and simulation control (JSON API for doppel-ctl: state, pause, resume, step,
                         reset, place, push, ball) on PORT (default 7580; 0 = any free port, printed at
                         start). If the default port is taken doppel runs without it and says so.
  --viewer-address ADDR  Address to serve it on (default 127.0.0.1: this machine only). Anyone who
                         can reach it can move the robots: name another address only on a network
                         you trust.
  --viewer-dir DIR       The viewer's page (index.html, viewer.js) from DIR instead of the source tree's
                         viewer/ (or $DOPPEL_VIEWER_DIR). three.js comes from Debian's libjs-three.
  --no-viewer            Serve neither the viewer nor simulation control.
  --handshake-socket PATH
                         Serve the session handshake (docs/handshake.md: control software asks for
                         robots, their cameras and sensors, and gets their links) on this Unix socket.
                         Default: LINK_DIR/handshake.sock.
  --handshake-port PORT  Also serve it over TCP on PORT (default 7590, used only if free; 0 = any free
                         port, printed at start).
  --handshake-address ADDR
                         Address of the TCP handshake (default 127.0.0.1: this machine only). Anyone
                         who can reach it can add and remove robots: name another address only on a
                         network you trust.
  --no-handshake-tcp     Serve the handshake on the Unix socket only.
  --no-handshake         Serve no handshake.
  --no-token             Let any local user and program use the control API and the TCP handshake
                         without the run's access token (the old behaviour; only for a machine of
                         your own with no other users: docs/security.md). Host and Origin are
                         checked still.
  --record FILE.mcap     Record the run to FILE (MCAP, docs/recording.md): every bus transaction with
                         its bytes and times, the world state at 100 Hz, servo tables, the scene.
                         Read it with doppel-bus report, doppel-replay or Foxglove.
  --record-cameras HZ    Also record each camera's still (PNG) HZ times a second (0.1..30).
  --record-compression zstd|lz4|none
                         Chunk compression of the recording (default zstd).
  --world-model          Give every simulated robot a world-model sensor (docs/multilevel.md): its own
                         pose, the balls, goal posts, side poles, field landmarks and the other robots,
                         in the field frame and relative to the robot, 30 times a second of simulation
                         time, published over iceoryx ("DoppelTruth", "robot<N>", "world_model") and
                         UDP; read them with doppel-truth. Noise, dropout and latency: doppel-ctl
                         world-model.
  --world-model-rate HZ  Messages per second of simulation time (0.1..1000; default 30).
  --world-model-fov DEG  Horizontal field of view about the head camera's optical axis (the heading
                         without a camera), 1..179; default 0: all around.
  --world-model-range M  Objects farther than M metres are not seen (default 0: no limit).
  --world-model-nearest-ball
                         Of several balls (a session's extra balls), report only the nearest seen.
  --truth-udp-port BASE  Robot N's world model goes to UDP port BASE+N (default 7600).
  --truth-udp-address ADDR
                         ...on this IPv4 address (default 127.0.0.1: this machine only; name another
                         address only for control software on another machine).
  --no-truth-iceoryx     Publish the world model over UDP only (no iceoryx RouDi needed).
  --gamecontroller [on|off]
                         Run a RoboCup GameController (Humanoid League protocol, struct version 12;
                         docs/gamecontroller.md) inside doppel, driven from doppel-ctl game and the
                         viewer. Off by default: a robot's software behaves differently once it hears
                         a GameController. doppel-ctl game on starts it later.
  --gc-teams A,B         Team numbers of team A (cyan, kicks off first) and B (default 1,2).
  --gc-players N         Players per team in the packets (default 4).
  --gc-destination ADDRESS:PORT
                         Where the game packets go (default 127.0.0.1:3838: this machine only). A
                         broadcast address (x.x.x.255) sends to the LAN: only if you name it.
  --gc-return ADDRESS:PORT
                         Where return packets are received (default 127.0.0.1:3939).
  --gc-watch ADDRESS:PORT|off
                         Watch for another GameController's packets and stop sending when one
                         appears (default 255.255.255.255:3838: broadcasts only, never the unicast
                         packets meant for the robots; shares the port with SO_REUSEADDR, so a
                         robot's software binding 3838 needs SO_REUSEADDR too, or use off).
  --teamcomm [ADDRESS:]PORT
                         Relay the robots' team messages (UDP) between their software on this
                         machine (docs/teamcomm.md), listening on ADDRESS:PORT (default address
                         127.0.0.1; port 0: any free port, printed at start).
  --teamcomm-robot TEAM:PLAYER:PORT
                         A robot's software that receives (and sends from) PORT; repeat. Robots can
                         also register while doppel runs (doppel-ctl teamcomm add).
  --teamcomm-robot-address ADDR
                         The address the robots' software runs on (default 127.0.0.1).
  --teamcomm-loss P, --teamcomm-delay-ms D, --teamcomm-jitter-ms J, --teamcomm-jitter uniform|normal,
  --teamcomm-burst-enter P, --teamcomm-burst-leave P, --teamcomm-burst-loss P, --teamcomm-seed S
                         The WiFi model of every link, as doppel-teamcomm's options of the same names.
  --lockstep             Simulation time instead of the wall clock (docs/lockstep.md): time advances
                         only while every thread of a controller started with `doppel-run --lockstep`
                         waits, as fast as the machine can. Implies --timing wire on its own clock.
  --hashes               With --lockstep: print `hash SECOND HEX` for every simulated second (bus
                         bytes in and out with their times, world state): equal runs, equal lines.
  --hashes-file FILE     The same lines to FILE instead of standard output.
  --lockstep-watchdog S  Wall seconds a controller thread may run without a wait doppel sees before
                         it is reported (default 5).
  --lockstep-epoch S     CLOCK_REALTIME at simulation time 0, Unix seconds (default: when doppel starts).
  --sensor-levels HZ     Publish every servo's, IMU's and foot board's registers decoded to SI units
                         beside the simulation's true values, HZ times per simulated second
                         (0.1..1000), as topic sensor_levels on the same transport (docs/multilevel.md).
  --list-robots          Print the shipped robots and exit.
  --help                 Print this text and exit.

The port baud rate set by the driver (termios, including BOTHER rates) must match the devices'
Baud Rate registers, as on real hardware; the robot file sets them (fumanoid-2011: 1 Mbps).
)";
}

Options parse_options(int argc, const char* const* argv) {
  Options options;
  CLI::App app("doppel", "doppel");
  app.set_help_flag();  // usage() is the help text; --help only sets Options::help
  app.option_defaults()->multi_option_policy(CLI::MultiOptionPolicy::TakeLast);
  app.add_flag("-h,--help", options.help);
  app.add_flag("--list-robots", options.list_robots);
  app.add_option("--robot", options.robots)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->allow_extra_args(false);
  app.add_option("--link-dir", options.link_dir)->check(not_empty("the directory"));
  app.add_flag("--allow-shared-link-dir", options.allow_shared_link_dir);
  app.add_option("--robots-dir", options.robots_dir);
  app.add_option("--session", options.session)->check(not_empty("the file name"));
  app.add_option_function<std::string>(
         "--timing",
         [&options](const std::string& mode) {
           options.timing = mode == "wire" ? bus::TimingMode::kWire : bus::TimingMode::kFast;
         })
      ->check(CLI::IsMember({"wire", "fast"}));
  app.add_option("--processing-us", options.processing_us)->transform(number_in<double>(0.0, 10000.0));
  app.add_option_function<std::string>(
         "--physics",
         [&options](const std::string& engine) {
           options.physics = engine == "none" ? std::nullopt : std::optional(physics::engine_from_name(engine));
         })
      ->check(CLI::IsMember({"ode", "bullet", "none"}));
  app.add_option("--solver-iterations", options.solver_iterations)->transform(number_in<int>(1, 1000));
  app.add_flag("--no-camera{false}", options.camera);
  app.add_flag("--external-roudi", options.external_roudi);
  app.add_flag("--verbose", options.verbose);
  app.add_flag("--no-hold{false}", options.hold);
  app.add_option("--state-dir", options.state_dir)->check(not_empty("the directory"));
  app.add_flag("--fresh", options.fresh);
  app.add_option("--viewer", options.viewer_port)->transform(number_in<uint16_t>(0, 65535));
  app.add_option("--viewer-address", options.viewer_address)->check(not_empty("the address"));
  app.add_option("--viewer-dir", options.viewer_dir)->check(not_empty("the folder"));
  app.add_flag("--no-viewer{false}", options.viewer);
  app.add_option("--rt-priority", options.rt_priority)->transform(number_in<int>(0, 99));
  app.add_option("--handshake-socket", options.handshake_socket)->check(not_empty("the socket path"));
  app.add_option("--handshake-port", options.handshake_port)->transform(number_in<uint16_t>(0, 65535));
  app.add_option("--handshake-address", options.handshake_address)->check(not_empty("the address"));
  app.add_flag("--no-handshake-tcp{false}", options.handshake_tcp);
  app.add_flag("--no-handshake{false}", options.handshake);
  app.add_flag("--no-token{false}", options.token);
  app.add_option("--record", options.record_path)->check(not_empty("the file name"));
  app.add_option("--record-cameras", options.record_camera_hz)->transform(number_in<double>(0.1, 30.0));
  app.add_option("--record-compression", options.record_compression)->check(CLI::IsMember({"zstd", "lz4", "none"}));
  app.add_option("--latency-timer", options.latency_timer_ms)->transform(number_in<uint32_t>(0, 255));
  contract::WorldModelSettings& world_model = options.world_model_settings;
  app.add_flag("--world-model", options.world_model);
  CLI::Option* rate = app.add_option("--world-model-rate", world_model.rate_hz)->transform(number_in<double>(0.1, 1000.0));
  CLI::Option* fov = app.add_option("--world-model-fov", world_model.fov_deg)->transform(number_in<double>(1.0, 179.0));
  CLI::Option* range = app.add_option("--world-model-range", world_model.max_range_m)->transform(number_in<double>(0.0, 100.0));
  CLI::Option* nearest = app.add_flag("--world-model-nearest-ball", world_model.nearest_ball_only);
  app.add_option("--truth-udp-port", options.truth_udp_port)->transform(number_in<uint16_t>(1, 65471));
  app.add_option("--truth-udp-address", options.truth_udp_address)->check(CLI::ValidIPV4);
  app.add_flag("--no-truth-iceoryx{false}", options.truth_iceoryx);
  std::string gamecontroller;
  app.add_option("--gamecontroller", gamecontroller)->expected(0, 1);
  std::string gc_teams;
  app.add_option("--gc-teams", gc_teams)->check(not_empty("the team numbers"));
  app.add_option("--gc-players", options.gc_players)->transform(number_in<int>(1, 11));
  app.add_option("--gc-destination", options.gc_destination)->check(not_empty("the address"));
  app.add_option("--gc-return", options.gc_return)->check(not_empty("the address"));
  app.add_option("--gc-watch", options.gc_watch)->check(not_empty("the address"));
  app.add_option("--teamcomm", options.teamcomm)->check(not_empty("the address"));
  app.add_option("--teamcomm-robot", options.teamcomm_robots)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app.add_option("--teamcomm-robot-address", options.teamcomm_robot_address)->check(not_empty("the address"));
  double teamcomm_delay_ms = 0.0, teamcomm_jitter_ms = 0.0;
  std::string teamcomm_jitter = "uniform";
  app.add_option("--teamcomm-loss", options.teamcomm_link.loss_probability)->transform(number_in<double>(0.0, 1.0));
  app.add_option("--teamcomm-delay-ms", teamcomm_delay_ms)->transform(number_in<double>(0.0, 60000.0));
  app.add_option("--teamcomm-jitter-ms", teamcomm_jitter_ms)->transform(number_in<double>(0.0, 60000.0));
  app.add_option("--teamcomm-jitter", teamcomm_jitter)->check(CLI::IsMember({"uniform", "normal"}));
  app.add_option("--teamcomm-burst-enter", options.teamcomm_link.p_good_to_bad)->transform(number_in<double>(0.0, 1.0));
  app.add_option("--teamcomm-burst-leave", options.teamcomm_link.p_bad_to_good)->transform(number_in<double>(0.0, 1.0));
  app.add_option("--teamcomm-burst-loss", options.teamcomm_link.loss_in_bad)->transform(number_in<double>(0.0, 1.0));
  app.add_option("--teamcomm-seed", options.teamcomm_seed);
  app.add_flag("--lockstep", options.lockstep);
  app.add_flag("--hashes", options.hashes);
  app.add_option("--hashes-file", options.hashes_file)->check(not_empty("the file name"));
  app.add_option("--lockstep-watchdog", options.lockstep_watchdog_s)->transform(number_in<double>(0.1, 3600.0));
  app.add_option("--lockstep-epoch", options.lockstep_epoch_s)->transform(number_in<double>(0.0, 1e11));
  app.add_option("--sensor-levels", options.sensor_levels_hz)->transform(number_in<double>(0.1, 1000.0));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    throw std::invalid_argument(std::string(e.what()) + " (see --help)");
  }
  for (int i = 0; i < argc; ++i) {
    options.command_line += (i > 0 ? " " : "") + std::string(argv[i]);
  }
  if (options.robots.empty()) {
    options.robots.emplace_back("fumanoid-2011");
  }
  if (app.count("--gamecontroller") > 0) {
    if (gamecontroller != "" && gamecontroller != "on" && gamecontroller != "off") {
      throw std::invalid_argument("--gamecontroller '" + gamecontroller + "': expected on or off (see --help)");
    }
    options.gamecontroller = gamecontroller != "off";
  }
  if (!gc_teams.empty()) {
    const auto comma = gc_teams.find(',');
    const auto team = [&gc_teams](const std::string& part) {
      if (part.empty() || part.size() > 3 || part.find_first_not_of("0123456789") != std::string::npos || std::stoi(part) > 255) {
        throw std::invalid_argument("--gc-teams '" + gc_teams + "': '" + part + "' is not a team number 0..255 (see --help)");
      }
      return std::stoi(part);
    };
    if (comma == std::string::npos) throw std::invalid_argument("--gc-teams '" + gc_teams + "': expected A,B (see --help)");
    options.gc_team_a = team(gc_teams.substr(0, comma));
    options.gc_team_b = team(gc_teams.substr(comma + 1));
    if (options.gc_team_a == options.gc_team_b) {
      throw std::invalid_argument("--gc-teams '" + gc_teams + "': the two teams need different numbers (see --help)");
    }
  }
  options.teamcomm_link.delay_ns = static_cast<int64_t>(teamcomm_delay_ms * 1e6);
  options.teamcomm_link.jitter_ns = static_cast<int64_t>(teamcomm_jitter_ms * 1e6);
  options.teamcomm_link.jitter = teamcomm_jitter == "normal" ? teamcomm::Jitter::kHalfNormal : teamcomm::Jitter::kUniform;
  options.teamcomm_link.burst = options.teamcomm_link.p_good_to_bad > 0.0;
  if (options.teamcomm.empty()) {
    for (const char* name : {"--teamcomm-robot", "--teamcomm-loss", "--teamcomm-delay-ms", "--teamcomm-jitter-ms",
                             "--teamcomm-burst-enter"}) {
      if (app.count(name) > 0) throw std::invalid_argument(std::string(name) + " needs --teamcomm [ADDRESS:]PORT (see --help)");
    }
  }
  if (options.record_camera_hz > 0.0 && options.record_path.empty()) {
    throw std::invalid_argument("--record-cameras needs --record FILE.mcap (see --help)");
  }
  if (rate->count() + fov->count() + range->count() + nearest->count() > 0) options.world_model = true;
  if ((options.hashes || !options.hashes_file.empty() || options.lockstep_epoch_s) && !options.lockstep) {
    throw std::invalid_argument("--hashes, --hashes-file and --lockstep-epoch need --lockstep (see --help)");
  }
  if (options.state_dir.empty()) {
    options.state_dir = default_state_dir();
  }
  return options;
}

}  // namespace doppel::gateway
