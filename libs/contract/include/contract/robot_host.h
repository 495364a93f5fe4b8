#pragma once
// Adding and removing robots while doppel runs: the contract between whoever asks (the session
// handshake in handshake/, a test) and the process that owns the world (gateway/), so that neither
// knows the other's insides. A request is checked completely before anything is built: a robot is
// either built whole, with every link it names working, or refused with the field it failed on and
// nothing left behind.

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "contract/world_model_settings.h"

namespace doppel::contract {

// Settings of one camera of the robot's figure (a camera mount, by name); unset = the file's.
struct CameraRequest {
  std::string name;                    // the mount's name in the robot file
  std::optional<uint32_t> width_px;
  std::optional<uint32_t> height_px;
  std::optional<double> fps;
  std::optional<std::string> format;   // rgb24, yuyv, uyvy, bayer_rggb, bayer_bggr, bayer_grbg, bayer_gbrg
  std::optional<std::string> lens;     // pinhole, equidistant, equisolid, stereographic
  std::optional<double> hfov_deg;
  std::optional<double> noise_gaussian_sigma;  // camera::NoiseConfig's fields, 8-bit levels
  std::optional<double> noise_salt_pepper_fraction;
  std::optional<uint64_t> noise_seed;
};

struct RobotRequest {
  // Exactly one of the two: a robot name or file as `doppel --robot` takes it, or the text of a
  // Robot Description File (libs/proto/robot.proto, protobuf text format).
  std::string robot;
  std::string description;
  std::optional<double> x_m, y_m, yaw_rad;  // where it stands (field frame); unset = the next free kick-off spot
  std::optional<uint32_t> team;             // 0 or 1 (team marker colour); unset = by kick-off spot
  // The cameras it wants: empty = every camera of the file with the file's settings; otherwise
  // only these, each with its overrides.
  std::vector<CameraRequest> cameras;
  bool cameras_off = false;                 // no camera at all
  std::optional<WorldModelSettings> world_model;  // unset = no world-model sensor
  bool sensor_levels = false;               // publish decoded and true sensor values (docs/multilevel.md)
};

// Where one of the robot's sensors or links can be reached.
struct Link {
  std::string kind;      // "bus", "camera", "world_model", "sensor_levels", "latency_timer"
  std::string name;      // the bus' ttyDXL<n>, the camera's stream name, ...
  std::string location;  // a path (pty link), "iceoryx:SERVICE/INSTANCE/EVENT", or "udp:127.0.0.1:PORT"
};

struct RobotAdded {
  uint32_t robot = 0;        // index, as the control API and the viewer number robots
  std::string name;          // the robot file's name
  std::vector<Link> links;
};

struct Refusal {
  std::string field;    // the request's field the problem is in, e.g. "cameras[0].width_px"; "" = none
  std::string message;  // what is wrong, for the user
};

using AddResult = std::variant<RobotAdded, Refusal>;

class RobotHost {
 public:
  virtual ~RobotHost() = default;
  // Builds the robot and starts serving it. Any thread; may take a while (loads files, builds the
  // body between two simulation steps).
  virtual AddResult add_robot(const RobotRequest& request) = 0;
  // Stops serving the robot and removes its links, body and streams. Refusal when there is no such
  // robot. Any thread.
  virtual std::optional<Refusal> remove_robot(uint32_t robot) = 0;
  // The robots now served, with their links.
  virtual std::vector<RobotAdded> robots() = 0;
};

}  // namespace doppel::contract
