#include "gateway/robot_config.h"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "camera/lens.h"
#include "camera/pixel_format.h"
#include "dynamixel/models.h"
#include "dynamixel/protocol2_models.h"
#include "proto/robot_file.h"

#ifndef DOPPEL_SOURCE_ROBOTS_DIR
#define DOPPEL_SOURCE_ROBOTS_DIR "robots"
#endif

namespace doppel::gateway {
namespace {

constexpr const char* kRobotSuffix = ".textproto";

bool ends_with(const std::string& text, std::string_view suffix) {
  return text.size() >= suffix.size() && text.compare(text.size() - suffix.size(), suffix.size(), suffix) == 0;
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
  if (bus.device_size() == 0) {
    file.fail(bus, "device", -1, "a bus needs at least one device");
  }
  std::set<uint32_t> ids;
  for (int d = 0; d < bus.device_size(); ++d) {
    const proto::Device& device = bus.device(d);
    const bool p2 = config.protocol == dynamixel::Protocol::kV2;
    const uint32_t max_id = p2 ? 252 : 253;
    if (device.id() > max_id) {
      file.fail(device, "id", -1, "ID " + std::to_string(device.id()) + " is outside 0.." + std::to_string(max_id));
    }
    if (!ids.insert(device.id()).second) {
      file.fail(device, "id", -1, "ID " + std::to_string(device.id()) + " is used twice on bus '" + config.name + "'");
    }
    if (p2) {
      const dynamixel::P2ModelSpec* model = nullptr;
      try {
        model = &dynamixel::p2_model_spec(device.model());
      } catch (const std::invalid_argument& e) {
        const bool p1_model = std::any_of(dynamixel::known_models().begin(), dynamixel::known_models().end(),
                                          [&](const dynamixel::ModelSpec* m) { return m->name == device.model(); });
        file.fail(device, "model", -1,
                  p1_model ? device.model() + " is a Protocol 1.0 model; this bus is PROTOCOL_2" : std::string(e.what()));
      }
      try {
        dynamixel::p2_baud_register(config.baud_bps, *model);
      } catch (const std::invalid_argument& e) {
        file.fail(bus, "baud_bps", -1, "device ID " + std::to_string(device.id()) + ": " + e.what());
      }
    } else {
      const dynamixel::ModelSpec* model = nullptr;
      try {
        model = &dynamixel::model_spec(device.model());
      } catch (const std::invalid_argument& e) {
        file.fail(device, "model", -1,
                  dynamixel::find_p2_model(device.model()) != nullptr
                      ? device.model() + " is a Protocol 2.0 model; set protocol: PROTOCOL_2 on this bus"
                      : std::string(e.what()));
      }
      try {
        dynamixel::p1_baud_register(config.baud_bps, *model);
      } catch (const std::invalid_argument& e) {
        file.fail(bus, "baud_bps", -1, "device ID " + std::to_string(device.id()) + ": " + e.what());
      }
    }
    DeviceConfig device_config;
    device_config.id = static_cast<uint8_t>(device.id());
    device_config.model = device.model();
    device_config.name = device.name();
    if (device.has_return_delay_time_raw()) {
      if (device.return_delay_time_raw() > 254) {
        file.fail(device, "return_delay_time_raw", -1, "must be 0..254 (2 µs per unit)");
      }
      device_config.return_delay_raw = static_cast<uint8_t>(device.return_delay_time_raw());
    }
    config.devices.push_back(std::move(device_config));
  }
  return config;
}

// The figure's camera mounts with their sensor and lens settings (unset fields keep the default
// head camera's).
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
    config.mount.body = body.bodies[setup.body].name;
    // The description's mount has x along the optical axis; the camera frame has z along it.
    config.mount.X_BC = model.X_DC * camera::camera_looking_along_x(Eigen::Vector3d::Zero());
    if (mount.width_px() != 0 || mount.height_px() != 0) {
      config.width_px = static_cast<int>(mount.width_px());
      config.height_px = static_cast<int>(mount.height_px());
    }
    if (mount.fps() != 0.0) {
      config.fps = mount.fps();
    }
    if (!mount.format().empty()) {
      try {
        config.format = camera::parse_pixel_format(mount.format());
      } catch (const std::invalid_argument& e) {
        file.fail(mount, "format", -1, e.what());
      }
    }
    camera::LensModel lens = config.lens.model;
    if (!mount.lens().empty()) {
      try {
        lens = camera::parse_lens_model(mount.lens());
      } catch (const std::invalid_argument& e) {
        file.fail(mount, "lens", -1, e.what());
      }
    }
    const double hfov_deg = mount.hfov_deg() != 0.0 ? mount.hfov_deg() : 120.0;
    try {
      config.lens = lens == camera::LensModel::kPinhole
                        ? camera::pinhole_from_hfov(config.width_px, config.height_px, hfov_deg)
                        : camera::fisheye_from_hfov(lens, config.width_px, config.height_px, hfov_deg);
      camera::validate(config);
    } catch (const std::invalid_argument& e) {
      file.fail(mount, "name", -1, e.what());
    }
    setups.push_back(std::move(setup));
  }
  return setups;
}

RobotConfig check_robot(const proto::RobotFile& file) {
  const proto::RobotDescription& robot = file.description();
  RobotConfig config;
  config.source = file.path();
  config.name = robot.name();
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
    config.body = physics::compile_robot(file);
    config.cameras = check_cameras(file, *config.body);
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
  return check_robot(proto::RobotFile::load(path));
}

RobotConfig parse_robot(const std::string& text, const std::string& path) {
  return check_robot(proto::RobotFile::parse(text, path));
}

}  // namespace doppel::gateway
