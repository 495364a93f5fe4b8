#pragma once
// A robot's buses and devices as the gateway builds them, read from a Robot Description File and
// checked: every model known, IDs in range and unique per bus, a baud rate the devices' Baud Rate
// register can hold. Setup code: errors throw std::invalid_argument naming file, line and field.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/supply.h"
#include "bus/adapter_profile.h"
#include "dynamixel/packet.h"
#include "camera/camera_config.h"
#include "physics/robot_model.h"

namespace doppel::gateway {

// One checked initial register value of a device (proto InitialRegister).
struct InitialValue {
  uint16_t address = 0;   // where the item starts
  int64_t value = 0;      // raw value, within the item's range
  bool eeprom = false;    // the item lies in the EEPROM area (a saved state replaces it)
  std::string item;       // its control-table name, for messages
  std::string location;   // "file:line:column" of the entry, for messages
};

struct DeviceConfig {
  uint8_t id = 0;                               // bus ID
  std::string model;                            // model name of the device registry (dynamixel/model_registry.h)
  std::string name;                             // role on the robot, e.g. "HEAD_YAW"
  std::optional<uint8_t> return_delay_raw;      // Return Delay Time register at power-on, unset = model default
  // Which registry the model comes from: kV1 = a Protocol 1.0 firmware model, kV2 = a Protocol 2.0
  // one (which may still start in Protocol 1.0 through Protocol Type = 1 in `initial`).
  dynamixel::Protocol firmware = dynamixel::Protocol::kV1;
  std::vector<InitialValue> initial;            // written after the factory defaults, in file order
};

struct BusConfig {
  std::string name;                              // label
  uint32_t baud_bps = 1000000;                   // rate the devices listen at
  dynamixel::Protocol protocol = dynamixel::Protocol::kV1;
  double supply_voltage_v = kDefaultSupplyVoltage_v;  // servo supply, V
  bus::AdapterProfile adapter = bus::AdapterProfile::kFtdi;  // USB adapter in front of the bus
  std::optional<uint32_t> latency_timer_ms;      // FTDI latency timer, ms; unset = --latency-timer
  std::vector<DeviceConfig> devices;             // in file order
};

// A camera of the robot's figure, ready to stream: its settings and the body it moves with.
struct CameraSetup {
  camera::CameraConfig config;  // name, sensor, lens, X_BC (mount on the body)
  std::size_t body = 0;         // index of the body in RobotModel::bodies
};

inline constexpr uint32_t kMaxSolverIterations = 1000;

struct RobotConfig {
  std::string name;                              // robot name from the file
  std::string description;                       // its one line for humans (may be empty)
  std::string source;                            // file it was read from
  std::vector<BusConfig> buses;                  // in port order
  std::optional<physics::RobotModel> body;       // the figure, when the file describes one
  std::vector<CameraSetup> cameras;              // its cameras (figure camera mounts), in file order
  std::optional<int> solver_iterations;          // figure.solver_iterations, when the file sets it
};

// A camera fixed in the field, from a session file.
struct WorldCameraSetup {
  camera::CameraConfig config;  // name, sensor, lens, noise; mount kWorld with X_WC
  std::string location;         // "file:line:column" of its entry, for messages about it
};

// What a session file (--session, libs/proto/session.proto) adds to the run.
struct SessionConfig {
  std::string source;                          // file it was read from
  std::vector<WorldCameraSetup> world_cameras;  // cameras fixed in the field, in file order
  std::vector<Eigen::Vector2d> extra_balls;     // balls 1, 2, ... (x, y on the carpet, field frame), in file order
};

// The default robots directory: $DOPPEL_ROBOTS_DIR, else the data/robots/ folder of the source tree.
std::string default_robots_dir();

// A robot name ("fumanoid-2011") becomes robots_dir/NAME.textproto; anything with a '/' or ending
// in ".textproto" is taken as a file path.
std::string resolve_robot_path(const std::string& name_or_file, const std::string& robots_dir);

// Names of the robots shipped in robots_dir (file names without .textproto), sorted.
std::vector<std::string> list_robots(const std::string& robots_dir);

// Loads and checks one robot. Throws std::runtime_error (unreadable, syntax) or
// std::invalid_argument ("file:line:col: Type.field: what") for semantic errors.
RobotConfig load_robot(const std::string& name_or_file, const std::string& robots_dir);

// Parses robot text (for tests); `path` names it in error messages.
RobotConfig parse_robot(const std::string& text, const std::string& path);

// Loads and checks a session file. Throws std::runtime_error (unreadable, syntax) or
// std::invalid_argument ("file:line:col: Type.field: what") for semantic errors (missing name or
// pose, duplicate name, a setting out of range).
SessionConfig load_session(const std::string& path);

// Parses session text (for tests); `path` names it in error messages.
SessionConfig parse_session(const std::string& text, const std::string& path);

}  // namespace doppel::gateway
