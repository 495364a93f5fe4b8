#pragma once
// Command-line options of the `doppel` executable. Each service (buses, world, state, cameras,
// control API, handshake, recorder, truth, GameController, team hub, lockstep) owns its struct here,
// in the order of the groups of --help, and declares its options in options.cpp: its group of the
// parser, its defaults (taken from its struct) and its checks (a function of its struct); --help is
// generated from those declarations. Options is their composition. Parsing is setup code: a bad
// option throws std::invalid_argument with a message meant for the user.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "bus/link_directory.h"
#include "contract/world_model_settings.h"
#include "bus/wire_timing.h"
#include "physics/engines.h"
#include "physics/world.h"
#include "teamcomm/link_model.h"

namespace doppel::gateway {

// The robots and their buses.
struct BusOptions {
  std::vector<std::string> robots;       // robot names (data/robots/NAME.textproto) or files; empty = default robot
  std::string robots_dir;                // where robot names are looked up; empty = built-in default
  std::string link_dir = bus::default_link_dir();  // where the stable ttyDXL links go
  bool allow_shared_link_dir = false;    // --allow-shared-link-dir: accept an unsafe link directory with a warning
  bus::TimingMode timing = bus::TimingMode::kWire;  // --timing wire|fast
  double processing_us = 50.0;           // firmware processing time before the Return Delay Time starts
  uint32_t latency_timer_ms = 0;         // USB adapter latency timer, 0 = none (a plain serial port)
  int rt_priority = 0;                   // SCHED_FIFO priority of the bus threads, 0 = normal scheduling
  bool list_robots = false;              // --list-robots: print the shipped robots and exit
};

// The physics world of the robots' bodies.
struct WorldOptions {
  // --physics ode|bullet|none: engine of the robots' bodies; nullopt (none) = every robot kinematic
  std::optional<physics::Engine> physics = physics::Engine::kOde;
  // --solver-iterations: constraint solver sweeps per physics step; unset = the largest a robot file
  // asks for (figure.solver_iterations), else physics::WorldOptions' default (10)
  std::optional<int> solver_iterations;
  bool hold = true;                      // a handler holds each robot until its first Torque Enable
  std::string session;                   // --session FILE: cameras fixed in the field; empty = none
  // Where robot r starts (a scenario's start poses); unset or beyond the list: the kick-off placement.
  std::vector<std::optional<physics::RobotPlacement>> placements;
};

// Persistent EEPROM (README "State"): --state-dir DIR keeps each robot's EEPROM areas there
// (parse_options' default: $XDG_STATE_HOME/doppel, else ~/.local/state/doppel); "" keeps nothing.
struct StateOptions {
  std::string dir;
  bool fresh = false;                    // --fresh: start from the robot files, overwrite their saved state
};

// The cameras over iceoryx.
struct CameraOptions {
  bool enabled = true;                   // --no-camera: stream no camera
  bool external_roudi = false;           // --external-roudi: require an already running iceoryx RouDi
  bool verbose = false;                  // --verbose: also print iceoryx's own log lines
};

// The web viewer and simulation control over HTTP (control/http_api.h, doppel-ctl, docs/viewer.md):
// --viewer PORT (0 = any free port), --viewer-address ADDR, --no-viewer. The default port is used
// only if it is free; a port the user names must be.
struct ViewerOptions {
  bool enabled = true;
  std::optional<uint16_t> port;          // unset = control::kDefaultPort
  std::string address = "127.0.0.1";
  std::string dir;                       // --viewer-dir DIR: the viewer's page; "" = $DOPPEL_VIEWER_DIR or the source tree's web/viewer/
  // The run's access token (contract/access_token.h, docs/security.md) for the HTTP API and the TCP
  // handshake, in LINK_DIR/token-PORT; --no-token: none (with a warning).
  bool token = true;
};

// The session handshake (handshake/, docs/handshake.md): control software asks for robots over a
// Unix socket (--handshake-socket PATH; "" = LINK_DIR/handshake.sock) and TCP (--handshake-port
// PORT, 0 = any free port; unset = handshake::kDefaultPort, used only if free;
// --handshake-address ADDR; --no-handshake-tcp); --no-handshake: neither. On by default on the
// command line (parse_options); off for a Gateway built in-process unless told.
struct HandshakeOptions {
  bool enabled = false;
  std::string socket;
  std::optional<uint16_t> port;
  std::string address = "127.0.0.1";
  bool tcp = true;
};

// The recorder (docs/recording.md).
struct RecordOptions {
  std::string path;                      // --record FILE.mcap: record the run; "" = off
  double camera_hz = 0.0;                // --record-cameras HZ: camera stills per second in the recording; 0 = none
  std::string compression = "zstd";      // --record-compression zstd|lz4|none
  bool progress = true;                  // the recorder's progress line on a terminal (a scenario run has its own)
};

// The world-model sensor (truth/, docs/multilevel.md): --world-model gives every simulated robot
// one with these settings (--world-model-rate, -fov, -range, --world-model-nearest-ball imply it);
// published over iceoryx (unless --no-truth-iceoryx) and UDP to --truth-udp-address:BASE+N.
struct TruthOptions {
  bool world_model = false;
  contract::WorldModelSettings world_model_settings;
  uint16_t udp_port = 7600;              // --truth-udp-port BASE (truth::kDefaultUdpBasePort)
  std::string udp_address = "127.0.0.1"; // --truth-udp-address ADDR
  bool iceoryx = true;                   // --no-truth-iceoryx: UDP only (no RouDi needed)
  double sensor_levels_hz = 0.0;         // --sensor-levels HZ: sensor levels per second of simulation time (docs/multilevel.md), published on the truth transport; 0 = off
};

// The GameController inside doppel (docs/gamecontroller.md): off unless --gamecontroller (or
// doppel-ctl game on); packets to 127.0.0.1 unless the user names another destination. The
// addresses stay text here; the gateway turns them into gamecontroller::GameControllerOptions.
struct GameControllerOptions {
  bool enabled = false;
  int team_a = 1, team_b = 2;            // --gc-teams A,B
  int players = 4;                       // --gc-players N
  std::string destination = "127.0.0.1:3838";  // --gc-destination ADDRESS:PORT
  std::string return_to = "127.0.0.1:3939";    // --gc-return ADDRESS:PORT
  std::string watch = "255.255.255.255:3838";  // --gc-watch ADDRESS:PORT|off: another GameController's broadcasts
};

// The team-communication hub (docs/teamcomm.md): --teamcomm [ADDRESS:]PORT; "" = none.
struct TeamcommOptions {
  std::string hub;
  std::vector<std::string> robots;       // --teamcomm-robot TEAM:PLAYER:PORT
  std::string robot_address = "127.0.0.1";
  teamcomm::LinkModelConfig link;        // --teamcomm-loss, -delay-ms, -jitter-ms, -jitter, -burst-*
  uint64_t seed = 1;
};

// Lockstep time (docs/lockstep.md): --lockstep, --hashes / --hashes-file FILE, --lockstep-watchdog S,
// --lockstep-epoch S.
struct LockstepOptions {
  bool enabled = false;
  bool hashes = false;                   // print `hash SECOND HEX` lines on standard output
  std::string hashes_file;               // the same lines to this file; "" = not
  double watchdog_s = 5.0;
  std::optional<double> epoch_s;         // CLOCK_REALTIME at simulation time 0; unset = doppel's start
};

struct Options {
  BusOptions buses;
  WorldOptions world;
  StateOptions state;
  CameraOptions cameras;
  ViewerOptions viewer;
  HandshakeOptions handshake;
  RecordOptions record;
  TruthOptions truth;
  GameControllerOptions gamecontroller;
  TeamcommOptions teamcomm;
  LockstepOptions lockstep;
  std::string command_line;              // argv joined by spaces (what a recording says it ran)
  bool help = false;                     // --help: print usage and exit
};

// Parses argv (argv[0] is the program). Throws std::invalid_argument naming the bad option.
Options parse_options(int argc, const char* const* argv);

// The --help text, generated from every service's option declarations: grouped, with defaults.
std::string usage();

}  // namespace doppel::gateway
