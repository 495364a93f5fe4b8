#pragma once
// Command-line options of the `doppel` executable. Each service (buses, world, state, cameras,
// control API, handshake, recorder, truth, GameController, team hub, lockstep) declares its own in
// options.cpp: its group of the parser, its defaults (taken from this struct) and its checks;
// --help is generated from those declarations. Parsing is setup code: a bad option throws
// std::invalid_argument with a message meant for the user.

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

struct Options {
  std::vector<std::string> robots;       // robot names (robots/NAME.textproto) or files; empty = default robot
  std::string link_dir = bus::default_link_dir();  // where the stable ttyDXL links go
  bool allow_shared_link_dir = false;    // --allow-shared-link-dir: accept an unsafe link directory with a warning
  std::string robots_dir;                // where robot names are looked up; empty = built-in default
  std::string session;                   // --session FILE: cameras fixed in the field; empty = none
  bus::TimingMode timing = bus::TimingMode::kWire;  // --timing wire|fast
  double processing_us = 50.0;           // firmware processing time before the Return Delay Time starts
  uint32_t latency_timer_ms = 0;         // USB adapter latency timer, 0 = none (a plain serial port)
  int rt_priority = 0;                   // SCHED_FIFO priority of the bus threads, 0 = normal scheduling
  // --physics ode|bullet|none: engine of the robots' bodies; nullopt (none) = every robot kinematic
  std::optional<physics::Engine> physics = physics::Engine::kOde;
  // --solver-iterations: constraint solver sweeps per physics step; unset = the largest a robot file
  // asks for (figure.solver_iterations), else physics::WorldOptions' default (10)
  std::optional<int> solver_iterations;
  bool hold = true;                      // a handler holds each robot until its first Torque Enable
  bool camera = true;                    // --no-camera: stream no camera
  bool verbose = false;                  // --verbose: also print iceoryx's own log lines
  bool external_roudi = false;           // --external-roudi: require an already running iceoryx RouDi
  // Persistent EEPROM (README "State"): --state-dir DIR keeps each robot's EEPROM areas there
  // (parse_options' default: $XDG_STATE_HOME/doppel, else ~/.local/state/doppel); "" keeps nothing.
  std::string state_dir;
  bool fresh = false;                    // --fresh: start from the robot files, overwrite their saved state
  // The web viewer and simulation control over HTTP (control/http_api.h, doppel-ctl, docs/viewer.md): --viewer PORT (0 = any free
  // port), --viewer-address ADDR, --no-viewer. The default port is used only if it is free; a port
  // the user names must be.
  bool viewer = true;
  std::optional<uint16_t> viewer_port;   // unset = control::kDefaultPort
  std::string viewer_address = "127.0.0.1";
  std::string viewer_dir;                // --viewer-dir DIR: the viewer's page; "" = $DOPPEL_VIEWER_DIR or the source tree's viewer/
  // The session handshake (handshake/, docs/handshake.md): control software asks for robots over a
  // Unix socket (--handshake-socket PATH; "" = LINK_DIR/handshake.sock) and TCP (--handshake-port
  // PORT, 0 = any free port; unset = handshake::kDefaultPort, used only if free;
  // --handshake-address ADDR; --no-handshake-tcp); --no-handshake: neither. On by default on the
  // command line (parse_options); off for a Gateway built in-process unless told.
  bool handshake = false;
  // The run's access token (contract/access_token.h, docs/security.md) for the HTTP API and the TCP
  // handshake, in LINK_DIR/token-PORT; --no-token: none (with a warning).
  bool token = true;
  std::string handshake_socket;
  bool handshake_tcp = true;
  std::optional<uint16_t> handshake_port;
  std::string handshake_address = "127.0.0.1";
  std::string record_path;               // --record FILE.mcap: record the run (docs/recording.md); "" = off
  double record_camera_hz = 0.0;         // --record-cameras HZ: camera stills per second in the recording; 0 = none
  std::string record_compression = "zstd";  // --record-compression zstd|lz4|none
  bool record_progress = true;           // the recorder's progress line on a terminal (a scenario run has its own)
  // The world-model sensor (truth/, docs/multilevel.md): --world-model gives every simulated robot
  // one with these settings (--world-model-rate, -fov, -range, --world-model-nearest-ball imply it);
  // published over iceoryx (unless --no-truth-iceoryx) and UDP to --truth-udp-address:BASE+N.
  bool world_model = false;
  contract::WorldModelSettings world_model_settings;
  uint16_t truth_udp_port = 7600;                // --truth-udp-port BASE (truth::kDefaultUdpBasePort)
  std::string truth_udp_address = "127.0.0.1";   // --truth-udp-address ADDR
  bool truth_iceoryx = true;                     // --no-truth-iceoryx: UDP only (no RouDi needed)
  // Lockstep time (docs/lockstep.md): --lockstep, --hashes / --hashes-file FILE, --lockstep-watchdog S,
  // --lockstep-epoch S.
  bool lockstep = false;
  bool hashes = false;                   // print `hash SECOND HEX` lines on standard output
  std::string hashes_file;               // the same lines to this file; "" = not
  double lockstep_watchdog_s = 5.0;
  std::optional<double> lockstep_epoch_s;  // CLOCK_REALTIME at simulation time 0; unset = doppel's start
  double sensor_levels_hz = 0.0;         // --sensor-levels HZ: sensor levels per second of simulation time (docs/multilevel.md), published on the truth transport; 0 = off
  std::string command_line;              // argv joined by spaces (what a recording says it ran)
  // Where robot r starts (a scenario's start poses); unset or beyond the list: the kick-off placement.
  std::vector<std::optional<physics::RobotPlacement>> placements;
  // The GameController inside doppel (docs/gamecontroller.md): off unless --gamecontroller (or
  // doppel-ctl game on); packets to 127.0.0.1 unless the user names another destination.
  bool gamecontroller = false;
  int gc_team_a = 1, gc_team_b = 2;      // --gc-teams A,B
  int gc_players = 4;                    // --gc-players N
  std::string gc_destination = "127.0.0.1:3838";  // --gc-destination ADDRESS:PORT
  std::string gc_return = "127.0.0.1:3939";       // --gc-return ADDRESS:PORT
  std::string gc_watch = "255.255.255.255:3838";  // --gc-watch ADDRESS:PORT|off: another GameController's broadcasts
  // The team-communication hub (docs/teamcomm.md): --teamcomm [ADDRESS:]PORT; "" = none.
  std::string teamcomm;
  std::vector<std::string> teamcomm_robots;     // --teamcomm-robot TEAM:PLAYER:PORT
  std::string teamcomm_robot_address = "127.0.0.1";
  teamcomm::LinkModelConfig teamcomm_link;      // --teamcomm-loss, -delay-ms, -jitter-ms, -jitter, -burst-*
  uint64_t teamcomm_seed = 1;
  bool list_robots = false;              // --list-robots: print the shipped robots and exit
  bool help = false;                     // --help: print usage and exit
};

// Parses argv (argv[0] is the program). Throws std::invalid_argument naming the bad option.
Options parse_options(int argc, const char* const* argv);

// The --help text, generated from every service's option declarations: grouped, with defaults.
std::string usage();

}  // namespace doppel::gateway
