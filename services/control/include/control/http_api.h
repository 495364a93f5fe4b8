#pragma once
// The simulation-control API over HTTP (JSON), served by doppel on loopback by default: what
// doppel-ctl and the viewer talk to, over the host's facets (contract/host.h). Every request is
// checked completely before a facet sees it, so a bad one changes nothing and gets a 4xx answer
// with {"error": "..."}. This is the one place where the contract's errors become HTTP statuses
// (http_status) and where paths are routed (cpp-httplib's patterns).
//
//   GET  /api/state                                   -> the state (state_json)
//   POST /api/pause | /api/resume | /api/reset        -> the state afterwards
//   POST /api/step   {"ms": 100}                      -> after the steps ran
//   POST /api/place  {"robot": 0 | "name", "x": 1.0, "y": 0.5, "yaw": 1.57}
//   POST /api/push   {"robot": ..., "fx": 20, "fy": 0, "fz": 0, "ms": 100}
//   POST /api/ball   {"x": 0.5, "y": 0}
//   GET  /api/scene                                   -> every visible shape (scene_json)
//   GET  /api/buses                                   -> every bus' servo table and counters (buses_json)
//   GET  /api/camera/NAME                             -> robot camera NAME's latest still (image/png)
//   GET  /api/replay                                  -> a replay's playback (replay_json); 404 when live
//   POST /api/replay {"position_s": 3.5, "speed": 0.5, "playing": true}   any of the three
//   GET  /api/analysis                                -> a replay's bus analysis (contract::Replay::bus_analysis); 404 when live
//   GET  /api/robots/N/world_model                    -> robot N's world-model sensor settings
//   PUT  /api/robots/N/world_model {"fov_deg": 90, "dropout": 0.1, ...}   the fields to change
//   GET  /api/game                                    -> the GameController (game_json); 404 without one
//   POST /api/game   {"command": "state", "state": "ready"}, goal, score, kickoff, penalize, ... (docs/control.md)
//   GET  /api/teamcomm                                -> the team-communication hub (teamcomm_json); 404 without one
//   GET|POST /api/teamcomm/robots {"team": 7, "player": 2, "port": 44002}
//   DELETE /api/teamcomm/robots/TEAM/PLAYER
//   GET  /api/faults                                  -> every fault of the run and the kinds (faults_json); 404 in a replay
//   POST /api/faults {"kind": "overheat", "robot": 0, "bus": 0, "id": 14, "rise_c_per_s": 5, "start_s": 12}
//   DELETE /api/faults | /api/faults/N                -> every fault / fault N ends now (docs/faults.md)
//   GET  /, /three/...                                -> the viewer's files (docs/viewer.md)
// Every request passes control/access.h's checks first: Host, Origin, Content-Type, the token.
// Units: m, rad, N, ms, field frame. docs/control.md has the details.

#include <cstdint>
#include <memory>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "control/access.h"
#include "contract/host.h"

namespace httplib {
class Server;
}

namespace doppel::control {

inline constexpr uint16_t kDefaultPort = 7580;
inline constexpr uint32_t kMaxStepMs = 60'000;
inline constexpr uint32_t kMaxPushMs = 10'000;
inline constexpr double kMaxPushForceN = 1000.0;

nlohmann::json state_json(const contract::SimState& state);
nlohmann::json scene_json(const contract::Scene& scene);
nlohmann::json buses_json(const std::vector<contract::BusTable>& buses);
nlohmann::json replay_json(const contract::ReplayStatus& status);
nlohmann::json game_json(const contract::GameStatus& status);
nlohmann::json teamcomm_json(const contract::TeamcommStatus& status);
nlohmann::json fault_json(const contract::FaultEntry& entry);
nlohmann::json faults_json(const contract::FaultList& list);
inline constexpr uint32_t kMaxGamePlayers = 11;  // MAX_NUM_PLAYERS of the Humanoid GameController header

// A refusal's HTTP status: kInvalid 400, kNotFound 404, kConflict 409, kUnavailable 503. The API's
// own refusals add 405 (a method the path does not take) and 500 (a host's answer that is broken).
int http_status(contract::ErrorKind kind) noexcept;

// Where the viewer's files are: the page (index.html, viewer.js, viewer.css) and three.js (Debian's
// libjs-three: three.min.js). Empty: not served.
struct StaticFiles {
  std::string viewer_dir;
  std::string three_dir;
};
// The viewer's folder: $DOPPEL_VIEWER_DIR, else the source tree's web/viewer/ (compiled in); three.js:
// $DOPPEL_THREE_DIR, else /usr/share/javascript/three.
StaticFiles default_static_files();
// Why `files` cannot be served ("" when they can): a folder without index.html, no three.min.js.
std::string static_files_problem(const StaticFiles& files);

// A request as the API takes it, for tests of the checks without a socket: `method` "GET" or
// "POST", "PUT" or "DELETE", `path` as in the table above, `body` the request body. Returns the HTTP status and the
// JSON answer.
struct Answer {
  int status = 200;
  nlohmann::json body;
};
Answer handle(const contract::Facets& host, const std::string& method, const std::string& path, const std::string& body);

class HttpApi {
 public:
  // Binds `address`:`port` at once (port 0: any free port), so that a port in use is reported
  // before anything runs. Throws std::runtime_error naming the address and port.
  // `files`: the viewer served at / (a folder that does not exist is an error naming it).
  // `token`: the access token every /api/ request must bring ("" = none: --no-token); the Host,
  // Origin and Content-Type checks apply either way (control/access.h).
  // `host`: its simulation (required) and the facets it offers; each outlives the API.
  HttpApi(const contract::Facets& host, const std::string& address, uint16_t port, const StaticFiles& files = {},
          std::string token = "");
  ~HttpApi();
  HttpApi(const HttpApi&) = delete;
  HttpApi& operator=(const HttpApi&) = delete;

  uint16_t port() const noexcept { return port_; }
  const std::string& address() const noexcept { return address_; }
  void start();  // serves on a thread of its own (and the library's worker threads)
  void stop();   // idempotent

 private:
  contract::Facets host_;
  std::string address_;
  uint16_t port_ = 0;
  AccessPolicy policy_;  // set once bound (the Host checks need the port); read by the server's threads
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
};

}  // namespace doppel::control
