#include "gateway/robot_config.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "body/motor_params.h"
#include "camera/lens.h"
#include "camera/pixel_format.h"
#include "dynamixel/models.h"
#include "dynamixel/protocol2_models.h"
#include "physics/carpet.h"
#include "physics/field.h"
#include "physics/robot_model.h"
#include "physics/world.h"
#include "proto/robot_file.h"
#include "proto/session_file.h"
#include "urdf/urdf_import.h"

#ifndef DOPPEL_SOURCE_ROBOTS_DIR
#define DOPPEL_SOURCE_ROBOTS_DIR "robots"
#endif

namespace doppel::gateway {
namespace {

constexpr const char* kRobotSuffix = ".textproto";

bool ends_with(const std::string& text, std::string_view suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// The registry a device's model comes from, given the protocol it should speak (its own or the bus').
dynamixel::Protocol check_firmware(const proto::RobotFile& file, const proto::Bus& bus, const proto::Device& device,
                                   dynamixel::Protocol bus_protocol) {
  const bool p1_model = std::any_of(dynamixel::known_models().begin(), dynamixel::known_models().end(),
                                    [&](const dynamixel::ModelSpec* m) { return m->name == device.model(); });
  const dynamixel::P2ModelSpec* p2_model = dynamixel::find_p2_model(device.model());
  const proto::Protocol wanted = device.protocol() != proto::PROTOCOL_UNSPECIFIED ? device.protocol() : bus.protocol();
  if (device.protocol() != proto::PROTOCOL_UNSPECIFIED && device.protocol() != proto::PROTOCOL_1 &&
      device.protocol() != proto::PROTOCOL_2) {
    file.fail(device, "protocol", -1, "unknown protocol (PROTOCOL_1 or PROTOCOL_2)");
  }
  if (p1_model) {
    if (wanted == proto::PROTOCOL_2) {
      file.fail(device, device.protocol() == proto::PROTOCOL_2 ? "protocol" : "model", -1,
                device.model() + " is a Protocol 1.0 model; this bus is PROTOCOL_2 (protocol: PROTOCOL_1 on the "
                "device puts a Protocol 1.0 firmware on it)");
    }
    return dynamixel::Protocol::kV1;
  }
  if (p2_model != nullptr) {
    if (wanted == proto::PROTOCOL_1 && device.protocol() != proto::PROTOCOL_1) {
      file.fail(device, "model", -1, device.model() + " is a Protocol 2.0 model; set protocol: PROTOCOL_2 on this bus");
    }
    if (wanted == proto::PROTOCOL_1 && p2_model->kind != dynamixel::P2DeviceKind::kServo) {
      file.fail(device, "protocol", -1, device.model() + " cannot speak Protocol 1.0 (only X and MX(2.0) servos can)");
    }
    return dynamixel::Protocol::kV2;
  }
  try {
    bus_protocol == dynamixel::Protocol::kV2 ? (void)dynamixel::p2_model_spec(device.model())
                                             : (void)dynamixel::model_spec(device.model());
  } catch (const std::invalid_argument& e) {
    file.fail(device, "model", -1, e.what());
  }
  return bus_protocol;
}

// The protocol a device answers at power-on, for its ID range.
bool speaks_protocol2(const proto::Bus& bus, const proto::Device& device) {
  const proto::Protocol wanted = device.protocol() != proto::PROTOCOL_UNSPECIFIED ? device.protocol() : bus.protocol();
  return wanted == proto::PROTOCOL_2;
}

// A control-table item as the initial-register check needs it, from either protocol's table.
struct Item {
  std::string_view name;
  uint16_t address = 0;
  bool writable = false;
  bool eeprom = false;
  int64_t min_raw = 0;
  int64_t max_raw = 0;
};

std::vector<Item> items_of(const std::string& model, dynamixel::Protocol firmware) {
  std::vector<Item> items;
  const auto add = [&](const auto& r) {
    if (r.name != "Reserved") {
      items.push_back(Item{r.name, r.address, r.access == dynamixel::Access::kReadWrite,
                           r.area == dynamixel::Area::kEeprom, r.min_raw, r.max_raw});
    }
  };
  if (firmware == dynamixel::Protocol::kV2) {
    for (const dynamixel::P2RegisterSpec& r : dynamixel::p2_model_spec(model).registers) add(r);
  } else {
    for (const dynamixel::RegisterSpec& r : dynamixel::model_spec(model).registers) add(r);
  }
  return items;
}

// A device's initial register values, checked against its model's control table.
std::vector<InitialValue> check_initial(const proto::RobotFile& file, const proto::Device& device,
                                        dynamixel::Protocol firmware, bool speaks_p2) {
  std::vector<InitialValue> values;
  const std::vector<Item> items = items_of(device.model(), firmware);
  if (device.initial_size() > 0 && items.empty()) {
    file.fail(device, "initial", 0, device.model() + " takes no initial register values (no control table items)");
  }
  std::set<uint16_t> seen;
  for (int i = 0; i < device.initial_size(); ++i) {
    const proto::InitialRegister& initial = device.initial(i);
    const Item* item = nullptr;
    if (initial.item().empty() == !initial.has_address()) {
      file.fail(initial, "item", -1, "give the item by name (item: \"Return Delay Time\") or by address, not both");
    }
    if (!initial.item().empty()) {
      for (const Item& candidate : items) {
        if (candidate.name == initial.item()) item = &candidate;
      }
      if (item == nullptr) {
        file.fail(initial, "item", -1, "'" + initial.item() + "' is no item of " + device.model() +
                                             "'s control table (names as in docs/devices.md)");
      }
    } else {
      for (const Item& candidate : items) {
        if (candidate.address == initial.address()) item = &candidate;
      }
      if (item == nullptr) {
        file.fail(initial, "address", -1, "no item of " + device.model() + " starts at address " +
                                              std::to_string(initial.address()));
      }
    }
    const std::string what = std::string(item->name) + " (" + std::to_string(item->address) + ")";
    const std::string field = initial.item().empty() ? "address" : "item";
    if (!item->writable) {
      file.fail(initial, field, -1, what + " is read-only");
    }
    if (initial.value() < item->min_raw || initial.value() > item->max_raw) {
      file.fail(initial, "value", -1, what + " = " + std::to_string(initial.value()) + " is outside " +
                                          std::to_string(item->min_raw) + ".." + std::to_string(item->max_raw));
    }
    if (!seen.insert(item->address).second) {
      file.fail(initial, field, -1, what + " is set twice");
    }
    if (item->name == "ID" && initial.value() != device.id()) {
      file.fail(initial, "value", -1, "ID " + std::to_string(initial.value()) + " conflicts with the device's id " +
                                          std::to_string(device.id()) + " (the id field is the ID at power-on)");
    }
    if (item->name == "Baud Rate") {
      file.fail(initial, field, -1, what + " is set by the bus' baud_bps");
    }
    if (item->name == "Return Delay Time" && device.has_return_delay_time_raw()) {
      file.fail(initial, field, -1, what + " is also set by return_delay_time_raw; keep one");
    }
    if (item->name == "Protocol Type" && device.protocol() != proto::PROTOCOL_UNSPECIFIED &&
        (initial.value() == 1) != (device.protocol() == proto::PROTOCOL_1)) {
      file.fail(initial, "value", -1, "Protocol Type " + std::to_string(initial.value()) +
                                          " conflicts with the device's protocol");
    }
    values.push_back(InitialValue{item->address, initial.value(), item->eeprom, std::string(item->name),
                                  file.location(initial, field)});
  }
  // An X / MX(2.0) servo told to speak Protocol 1.0 starts with Protocol Type 1.
  if (firmware == dynamixel::Protocol::kV2 && !speaks_p2 && seen.count(dynamixel::x430::kProtocolType) == 0) {
    values.insert(values.begin(), InitialValue{dynamixel::x430::kProtocolType, dynamixel::x430::kProtocolType1, true,
                                               "Protocol Type", file.location(device, "protocol")});
  }
  return values;
}

BusConfig check_bus(const proto::RobotFile& file, const proto::RobotDescription& robot, int bus_index) {
  const proto::Bus& bus = robot.bus(bus_index);
  BusConfig config;
  config.name = bus.name().empty() ? "bus" + std::to_string(bus_index) : bus.name();
  switch (bus.protocol()) {
    case proto::PROTOCOL_1:
      config.protocol = dynamixel::Protocol::kV1;
      break;
    case proto::PROTOCOL_2:
      config.protocol = dynamixel::Protocol::kV2;
      break;
    default:
      file.fail(bus, "protocol", -1, "missing or unknown protocol (PROTOCOL_1 or PROTOCOL_2)");
  }
  if (bus.baud_bps() == 0) {
    file.fail(bus, "baud_bps", -1, "missing baud rate (e.g. 1000000)");
  }
  config.baud_bps = bus.baud_bps();
  if (bus.has_supply_voltage_v()) {
    if (!(bus.supply_voltage_v() > 0.0 && bus.supply_voltage_v() <= 30.0)) {
      file.fail(bus, "supply_voltage_v", -1, "must be in (0, 30] V");
    }
    config.supply_voltage_v = bus.supply_voltage_v();
  }
  if (bus.adapter() == "usb2ax") {
    config.adapter = bus::AdapterProfile::kUsb2ax;
  } else if (!bus.adapter().empty() && bus.adapter() != "ftdi") {
    file.fail(bus, "adapter", -1, "unknown adapter '" + bus.adapter() + "' (ftdi or usb2ax)");
  }
  if (bus.has_latency_timer_ms()) {
    if (config.adapter != bus::AdapterProfile::kFtdi) {
      file.fail(bus, "latency_timer_ms", -1, "a USB2AX has no latency timer (only adapter \"ftdi\" has one)");
    }
    if (bus.latency_timer_ms() < 1 || bus.latency_timer_ms() > 255) {
      file.fail(bus, "latency_timer_ms", -1, "must be 1..255 ms (the FTDI latency timer's range)");
    }
    config.latency_timer_ms = bus.latency_timer_ms();
  }
  if (bus.device_size() == 0) {
    file.fail(bus, "device", -1, "a bus needs at least one device");
  }
  std::set<uint32_t> ids;
  for (int d = 0; d < bus.device_size(); ++d) {
    const proto::Device& device = bus.device(d);
    DeviceConfig device_config;
    device_config.firmware = check_firmware(file, bus, device, config.protocol);
    const bool p2 = speaks_protocol2(bus, device);
    const uint32_t max_id = p2 ? 252 : 253;
    if (!device.has_id()) {
      file.fail(device, "id", -1, "missing ID (0.." + std::to_string(max_id) + ")");
    }
    if (device.id() > max_id) {
      file.fail(device, "id", -1, "ID " + std::to_string(device.id()) + " is outside 0.." + std::to_string(max_id));
    }
    if (config.adapter == bus::AdapterProfile::kUsb2ax && device.id() == 253) {
      file.fail(device, "id", -1, "ID 253 is the USB2AX adapter's own ID on this bus (adapter: \"usb2ax\")");
    }
    if (!ids.insert(device.id()).second) {
      file.fail(device, "id", -1, "ID " + std::to_string(device.id()) + " is used twice on bus '" + config.name + "'");
    }
    try {
      if (device_config.firmware == dynamixel::Protocol::kV2) {
        dynamixel::p2_baud_register(config.baud_bps, dynamixel::p2_model_spec(device.model()));
      } else {
        dynamixel::p1_baud_register(config.baud_bps, dynamixel::model_spec(device.model()));
      }
    } catch (const std::invalid_argument& e) {
      file.fail(bus, "baud_bps", -1, "device ID " + std::to_string(device.id()) + ": " + e.what());
    }
    device_config.id = static_cast<uint8_t>(device.id());
    device_config.model = device.model();
    device_config.name = device.name();
    if (device.has_return_delay_time_raw()) {
      if (device.return_delay_time_raw() > 254) {
        file.fail(device, "return_delay_time_raw", -1, "must be 0..254 (2 µs per unit)");
      }
      device_config.return_delay_raw = static_cast<uint8_t>(device.return_delay_time_raw());
    }
    device_config.initial = check_initial(file, device, device_config.firmware, p2);
    config.devices.push_back(std::move(device_config));
  }
  return config;
}

// A camera's noise filters; every field is checked against camera::validate's ranges.
camera::NoiseConfig check_noise(const proto::TextFile& file, const proto::CameraNoise& noise) {
  camera::NoiseConfig config;
  config.gaussian_sigma = noise.gaussian_sigma();
  config.shot_noise_gain = noise.shot_noise_gain();
  config.salt_pepper_fraction = noise.salt_pepper_fraction();
  config.vignetting = noise.vignetting();
  config.wb_red_gain = noise.has_wb_red_gain() ? noise.wb_red_gain() : 1.0;
  config.wb_green_gain = noise.has_wb_green_gain() ? noise.wb_green_gain() : 1.0;
  config.wb_blue_gain = noise.has_wb_blue_gain() ? noise.wb_blue_gain() : 1.0;
  config.seed = noise.seed();
  const std::string_view bad = camera::invalid_noise_field(config);
  if (!bad.empty()) {
    try {
      camera::validate(config);
    } catch (const std::invalid_argument& e) {
      const std::string what = e.what();  // "NoiseConfig.<field> must lie in ..."
      const std::size_t verb = what.find(" must");
      file.fail(noise, bad, -1, verb == std::string::npos ? what : what.substr(verb + 1));
    }
  }
  return config;
}

// Sensor, lens and noise settings, written alike in a robot's CameraMount and a session's
// WorldCamera; unset fields keep the default head camera's.
template <typename CameraMessage>
void check_camera_settings(const proto::TextFile& file, const CameraMessage& message, camera::CameraConfig& config) {
  if (message.width_px() != 0 || message.height_px() != 0) {
    config.width_px = static_cast<int>(message.width_px());
    config.height_px = static_cast<int>(message.height_px());
  }
  if (message.fps() != 0.0) {
    config.fps = message.fps();
  }
  if (!message.format().empty()) {
    try {
      config.format = camera::parse_pixel_format(message.format());
    } catch (const std::invalid_argument& e) {
      file.fail(message, "format", -1, e.what());
    }
  }
  camera::LensModel lens = config.lens.model;
  if (!message.lens().empty()) {
    try {
      lens = camera::parse_lens_model(message.lens());
    } catch (const std::invalid_argument& e) {
      file.fail(message, "lens", -1, e.what());
    }
  }
  if (message.has_noise()) {
    config.noise = check_noise(file, message.noise());
  }
  const double hfov_deg = message.hfov_deg() != 0.0 ? message.hfov_deg() : 120.0;
  try {
    config.lens = lens == camera::LensModel::kPinhole
                      ? camera::pinhole_from_hfov(config.width_px, config.height_px, hfov_deg)
                      : camera::fisheye_from_hfov(lens, config.width_px, config.height_px, hfov_deg);
    camera::validate(config);
  } catch (const std::invalid_argument& e) {
    file.fail(message, "name", -1, e.what());
  }
}

// The figure's camera mounts with their sensor, lens and noise settings.
std::vector<CameraSetup> check_cameras(const proto::RobotFile& file, const physics::RobotModel& body) {
  std::vector<CameraSetup> setups;
  const proto::Figure& figure = file.description().figure();
  for (int c = 0; c < figure.camera_size(); ++c) {
    const proto::CameraMount& mount = figure.camera(c);
    const physics::CameraModel& model = body.cameras.at(static_cast<std::size_t>(c));
    CameraSetup setup;
    setup.body = static_cast<std::size_t>(model.body);
    camera::CameraConfig& config = setup.config;
    config = camera::default_head_camera();
    config.name = model.name;
    config.robot_file_order = c;
    config.mount.body = body.bodies[setup.body].name;
    // The description's mount has x along the optical axis; the camera frame has z along it.
    config.mount.X_BC = model.X_DC * camera::camera_looking_along_x(Eigen::Vector3d::Zero());
    check_camera_settings(file, mount, config);
    setups.push_back(std::move(setup));
  }
  return setups;
}

bool finite(const proto::Vector3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

SessionConfig check_session(const proto::SessionFile& file) {
  const proto::Session& session = file.session();
  SessionConfig config;
  config.source = file.path();
  std::set<std::string> names;
  for (int c = 0; c < session.camera_size(); ++c) {
    const proto::WorldCamera& world_camera = session.camera(c);
    if (world_camera.name().empty()) {
      file.fail(world_camera, "name", -1, "missing camera name");
    }
    if (!names.insert(world_camera.name()).second) {
      file.fail(world_camera, "name", -1, "camera '" + world_camera.name() + "' is named twice");
    }
    if (!world_camera.has_pose()) {
      file.fail(world_camera, "pose", -1, "missing pose (camera position_m and rpy_deg in the field frame)");
    }
    const proto::Pose& pose = world_camera.pose();
    if (!finite(pose.position_m())) {
      file.fail(pose, "position_m", -1, "must be finite");
    }
    if (!finite(pose.rpy_deg())) {
      file.fail(pose, "rpy_deg", -1, "must be finite");
    }
    WorldCameraSetup setup;
    setup.location = file.location(session, "camera", c);
    camera::CameraConfig& camera_config = setup.config;
    camera_config = camera::default_head_camera();
    camera_config.name = world_camera.name();
    camera_config.mount.kind = camera::CameraMount::Kind::kWorld;
    camera_config.mount.body.clear();
    // Written like a body mount (x along the optical axis); the camera frame has z along it.
    Eigen::Isometry3d X_WM = Eigen::Isometry3d::Identity();
    X_WM.linear() = physics::rotation_from_rpy_deg(pose.rpy_deg().x(), pose.rpy_deg().y(), pose.rpy_deg().z());
    X_WM.translation() = Eigen::Vector3d(pose.position_m().x(), pose.position_m().y(), pose.position_m().z());
    camera_config.mount.X_WC = X_WM * camera::camera_looking_along_x(Eigen::Vector3d::Zero());
    check_camera_settings(file, world_camera, camera_config);
    config.world_cameras.push_back(std::move(setup));
  }
  if (session.ball_size() > static_cast<int>(physics::kMaxExtraBalls)) {
    file.fail(session, "ball", static_cast<int>(physics::kMaxExtraBalls),
              "at most " + std::to_string(physics::kMaxExtraBalls) + " extra balls");
  }
  const physics::FieldSpec field;
  for (int b = 0; b < session.ball_size(); ++b) {
    const proto::Ball& ball = session.ball(b);
    if (!ball.has_position_m()) file.fail(session, "ball", b, "missing position_m (the ball's x, y in the field frame)");
    const proto::Vector3& p = ball.position_m();
    if (!finite(p)) file.fail(ball, "position_m", -1, "must be finite");
    const double half_length = physics::carpet_half_length_m(field);
    const double half_width = physics::carpet_half_width_m(field);
    if (std::abs(p.x()) > half_length || std::abs(p.y()) > half_width) {
      file.fail(ball, "position_m", -1, "(" + std::to_string(p.x()) + ", " + std::to_string(p.y()) +
                                            ") is off the carpet (|x| <= " + std::to_string(half_length) +
                                            ", |y| <= " + std::to_string(half_width) + " m)");
    }
    config.extra_balls.emplace_back(p.x(), p.y());
  }
  return config;
}

RobotConfig check_robot(const proto::RobotFile& file) {
  const proto::RobotDescription& robot = file.description();
  RobotConfig config;
  config.source = file.path();
  config.name = robot.name();
  config.description = robot.description();
  if (config.name.empty()) {
    file.fail(robot, "name", -1, "missing robot name");
  }
  if (robot.bus_size() == 0) {
    file.fail(robot, "bus", -1, "a robot needs at least one bus");
  }
  for (int b = 0; b < robot.bus_size(); ++b) {
    config.buses.push_back(check_bus(file, robot, b));
  }
  if (robot.has_figure()) {
    config.body = physics::compile_robot(file, body::motor_catalog());
    config.cameras = check_cameras(file, *config.body);
    if (robot.figure().has_solver_iterations()) {
      const uint32_t sweeps = robot.figure().solver_iterations();
      if (sweeps < 1 || sweeps > kMaxSolverIterations) {
        file.fail(robot.figure(), "solver_iterations", -1,
                  "must be within 1.." + std::to_string(kMaxSolverIterations) + ", got " + std::to_string(sweeps));
      }
      config.solver_iterations = static_cast<int>(sweeps);
    }
  }
  return config;
}

}  // namespace

std::string default_robots_dir() {
  if (const char* dir = std::getenv("DOPPEL_ROBOTS_DIR"); dir != nullptr && *dir != '\0') {
    return dir;
  }
  return DOPPEL_SOURCE_ROBOTS_DIR;
}

std::string resolve_robot_path(const std::string& name_or_file, const std::string& robots_dir) {
  if (name_or_file.find('/') != std::string::npos || ends_with(name_or_file, kRobotSuffix)) {
    return name_or_file;
  }
  return (std::filesystem::path(robots_dir) / (name_or_file + kRobotSuffix)).string();
}

std::vector<std::string> list_robots(const std::string& robots_dir) {
  std::vector<std::string> names;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(robots_dir, error)) {
    std::string file = entry.path().filename().string();
    if (entry.is_regular_file() && ends_with(file, kRobotSuffix)) {
      names.push_back(file.substr(0, file.size() - std::string_view(kRobotSuffix).size()));
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

RobotConfig load_robot(const std::string& name_or_file, const std::string& robots_dir) {
  std::string path = resolve_robot_path(name_or_file, robots_dir);
  if (path != name_or_file && !std::filesystem::exists(path)) {
    std::string known;
    for (const std::string& name : list_robots(robots_dir)) {
      known += (known.empty() ? "" : ", ") + name;
    }
    throw std::invalid_argument("unknown robot '" + name_or_file + "' (no " + path + "; shipped robots: " + known + ")");
  }
  return check_robot(urdf::load_robot_file(path));
}

RobotConfig parse_robot(const std::string& text, const std::string& path) {
  return check_robot(urdf::parse_robot_file(text, path));
}

SessionConfig load_session(const std::string& path) { return check_session(proto::SessionFile::load(path)); }

SessionConfig parse_session(const std::string& text, const std::string& path) {
  return check_session(proto::SessionFile::parse(text, path));
}

}  // namespace doppel::gateway
