#include "handshake/request.h"

#include <array>
#include <cmath>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

namespace doppel::handshake {
namespace {

// The first problem found, with its field path; checks stop at the first.
struct Checker {
  std::optional<contract::Refusal> refusal;

  bool fail(std::string field, std::string message) {
    if (!refusal) {
      refusal = contract::Refusal{std::move(field), std::move(message)};
    }
    return false;
  }
  bool ok() const noexcept { return !refusal; }
};

std::string number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// Where a field's limits come from: camera::validate (libs/camera/src/camera_config.cpp), camera::NoiseConfig
// (libs/camera/src/noise.cpp) and control/world_model_settings.h. The field size is an assumption: the
// largest RoboCup field with its border is 14 m x 9 m plus 2 m; 100 m leaves room for any scene.
constexpr double kMaxPlacementM = 100.0;
constexpr std::array<std::string_view, 7> kFormats = {"rgb24",      "yuyv",       "uyvy",      "bayer_rggb",
                                                       "bayer_bggr", "bayer_grbg", "bayer_gbrg"};
constexpr std::array<std::string_view, 4> kLenses = {"pinhole", "equidistant", "equisolid", "stereographic"};
constexpr std::size_t kMaxRobotNameBytes = 4096;  // PATH_MAX: a name or a file path

bool member(std::string_view value, auto const& names) {
  for (std::string_view name : names) {
    if (value == name) {
      return true;
    }
  }
  return false;
}

std::string list(auto const& names) {
  std::string out;
  for (std::string_view name : names) {
    out += (out.empty() ? "" : ", ") + std::string(name);
  }
  return out;
}

// value within [lo, hi] (lo_open / hi_open: excluded), finite.
bool in_range(Checker& c, const std::string& field, double value, double lo, double hi, bool lo_open, bool hi_open) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && (hi_open ? value < hi : value <= hi);
  if (!ok) {
    return c.fail(field, "must lie in " + std::string(lo_open ? "(" : "[") + number(lo) + ", " + number(hi) +
                             (hi_open ? ")" : "]") + ", got " + number(value));
  }
  return true;
}

bool camera_name_ok(std::string_view name) {
  if (name.empty() || name.size() > 63) {
    return false;
  }
  for (char ch : name) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_' ||
                    ch == '.' || ch == '/' || ch == '-';
    if (!ok) {
      return false;
    }
  }
  return true;
}

contract::CameraRequest check_camera(Checker& c, const wire::CameraRequest& m, const std::string& at) {
  contract::CameraRequest r;
  if (!camera_name_ok(m.name())) {
    c.fail(at + ".name", m.name().empty() ? "must name a camera mount of the robot file"
                                          : "must have 1..63 characters of A-Z a-z 0-9 _ . / -");
  }
  r.name = m.name();
  if (m.has_width_px()) {
    if (m.width_px() < 2 || m.width_px() > 8192) {
      c.fail(at + ".width_px", "must be 2..8192, got " + std::to_string(m.width_px()));
    }
    r.width_px = m.width_px();
  }
  if (m.has_height_px()) {
    if (m.height_px() < 2 || m.height_px() > 8192) {
      c.fail(at + ".height_px", "must be 2..8192, got " + std::to_string(m.height_px()));
    }
    r.height_px = m.height_px();
  }
  if (m.has_fps()) {
    in_range(c, at + ".fps", m.fps(), 0.0, 1000.0, true, false);
    r.fps = m.fps();
  }
  if (m.has_format()) {
    if (!member(m.format(), kFormats)) {
      c.fail(at + ".format", "must be one of " + list(kFormats) + ", got '" + m.format() + "'");
    }
    r.format = m.format();
  }
  if (m.has_lens()) {
    if (!member(m.lens(), kLenses)) {
      c.fail(at + ".lens", "must be one of " + list(kLenses) + ", got '" + m.lens() + "'");
    }
    r.lens = m.lens();
  }
  if (m.has_hfov_deg()) {
    const double limit = m.has_lens() && m.lens() == "pinhole" ? 170.0 : 180.0;
    in_range(c, at + ".hfov_deg", m.hfov_deg(), 0.0, limit, true, true);
    r.hfov_deg = m.hfov_deg();
  }
  if (m.has_width_px() && m.width_px() % 2 != 0 && m.has_format() && (m.format() == "yuyv" || m.format() == "uyvy")) {
    c.fail(at + ".width_px", "must be even for " + m.format() + " (YUV 4:2:2 pairs pixels), got " +
                                 std::to_string(m.width_px()));
  }
  if (m.has_noise()) {
    const wire::CameraNoise& n = m.noise();
    if (n.has_gaussian_sigma()) {
      in_range(c, at + ".noise.gaussian_sigma", n.gaussian_sigma(), 0.0, 255.0, false, false);
      r.noise_gaussian_sigma = n.gaussian_sigma();
    }
    if (n.has_salt_pepper_fraction()) {
      in_range(c, at + ".noise.salt_pepper_fraction", n.salt_pepper_fraction(), 0.0, 1.0, false, false);
      r.noise_salt_pepper_fraction = n.salt_pepper_fraction();
    }
    if (n.has_seed()) {
      r.noise_seed = n.seed();
    }
  }
  return r;
}

contract::WorldModelSettings check_world_model(Checker& c, const wire::WorldModelRequest& m) {
  const std::string at = "add_robot.world_model";
  contract::WorldModelSettings s;
  s.enabled = true;
  if (m.has_rate_hz()) {
    in_range(c, at + ".rate_hz", m.rate_hz(), 0.0, 1000.0, true, false);
    s.rate_hz = m.rate_hz();
  }
  if (m.has_fov_deg()) {
    if (m.fov_deg() != 0.0) {
      in_range(c, at + ".fov_deg", m.fov_deg(), 0.0, 180.0, true, true);
    }
    s.fov_deg = m.fov_deg();
  }
  if (m.has_max_range_m()) {
    in_range(c, at + ".max_range_m", m.max_range_m(), 0.0, 1e6, false, false);
    s.max_range_m = m.max_range_m();
  }
  if (m.has_nearest_ball_only()) {
    s.nearest_ball_only = m.nearest_ball_only();
  }
  if (m.has_position_sigma_m()) {
    in_range(c, at + ".position_sigma_m", m.position_sigma_m(), 0.0, 1e3, false, false);
    s.position_sigma_m = m.position_sigma_m();
  }
  if (m.has_angle_sigma_rad()) {
    in_range(c, at + ".angle_sigma_rad", m.angle_sigma_rad(), 0.0, 1e3, false, false);
    s.angle_sigma_rad = m.angle_sigma_rad();
  }
  if (m.has_dropout()) {
    in_range(c, at + ".dropout", m.dropout(), 0.0, 1.0, false, true);
    s.dropout = m.dropout();
  }
  if (m.has_latency_s()) {
    in_range(c, at + ".latency_s", m.latency_s(), 0.0, 1.0, false, false);
    s.latency_s = m.latency_s();
  }
  if (m.has_seed()) {
    s.seed = m.seed();
  }
  return s;
}

}  // namespace

std::variant<contract::RobotRequest, contract::Refusal> check_add_robot(const wire::AddRobot& m) {
  Checker c;
  contract::RobotRequest r;
  if (m.robot().empty() == m.description().empty()) {
    c.fail("add_robot.robot", m.robot().empty() ? "name a robot (or a robot file), or give a description"
                                                : "give a robot or a description, not both");
  } else if (m.robot().size() > kMaxRobotNameBytes || m.robot().find('\0') != std::string::npos) {
    c.fail("add_robot.robot", "must be a robot name or a file path (at most 4096 bytes, no NUL)");
  }
  r.robot = m.robot();
  r.description = m.description();
  if (m.has_x_m()) {
    in_range(c, "add_robot.x_m", m.x_m(), -kMaxPlacementM, kMaxPlacementM, false, false);
    r.x_m = m.x_m();
  }
  if (m.has_y_m()) {
    in_range(c, "add_robot.y_m", m.y_m(), -kMaxPlacementM, kMaxPlacementM, false, false);
    r.y_m = m.y_m();
  }
  if (m.has_yaw_rad()) {
    in_range(c, "add_robot.yaw_rad", m.yaw_rad(), -2.0 * std::numbers::pi, 2.0 * std::numbers::pi, false, false);
    r.yaw_rad = m.yaw_rad();
  }
  if (m.has_team()) {
    if (m.team() > 1) {
      c.fail("add_robot.team", "must be 0 or 1, got " + std::to_string(m.team()));
    }
    r.team = m.team();
  }
  if (m.cameras_off() && m.camera_size() > 0) {
    c.fail("add_robot.cameras_off", "asks for no camera, but the request lists " + std::to_string(m.camera_size()));
  }
  r.cameras_off = m.cameras_off();
  std::set<std::string> names;
  for (int i = 0; i < m.camera_size(); ++i) {
    const std::string at = "add_robot.camera[" + std::to_string(i) + "]";
    r.cameras.push_back(check_camera(c, m.camera(i), at));
    if (!names.insert(m.camera(i).name()).second) {
      c.fail(at + ".name", "'" + m.camera(i).name() + "' is asked for twice");
    }
  }
  if (m.has_world_model()) {
    r.world_model = check_world_model(c, m.world_model());
  }
  r.sensor_levels = m.sensor_levels();
  if (!c.ok()) {
    return *c.refusal;
  }
  return r;
}

std::string proto_field_path(std::string_view host_field) {
  if (host_field.empty()) {
    return "add_robot";
  }
  std::string out = "add_robot.";
  std::string_view rest = host_field;
  if (rest == "cameras") {
    return out + "camera";  // the list as a whole
  }
  if (rest.starts_with("cameras[")) {
    out += "camera[";
    rest.remove_prefix(8);
    const std::size_t close = rest.find(']');
    if (close != std::string_view::npos) {
      out.append(rest.substr(0, close + 1));
      rest.remove_prefix(close + 1);
      if (rest.starts_with(".noise_")) {
        out += ".noise.";
        rest.remove_prefix(7);
      }
    }
  }
  out.append(rest);
  return out;
}

wire::Robot to_wire(const contract::RobotAdded& robot) {
  wire::Robot out;
  out.set_robot(robot.robot);
  out.set_name(robot.name);
  for (const contract::Link& link : robot.links) {
    wire::Link* l = out.add_link();
    l->set_kind(link.kind);
    l->set_name(link.name);
    l->set_location(link.location);
  }
  return out;
}

}  // namespace doppel::handshake
