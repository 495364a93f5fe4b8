#include "body/servo_check.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "body/motor_params.h"
#include "body/physics_body.h"
#include "dynamixel/model_registry.h"
#include "dynamixel/servo_controller.h"
#include "physics/robot_model.h"
#include "physics/world.h"

namespace doppel::body {
namespace {

using nlohmann::json;

[[noreturn]] void fail(std::string_view name, const std::string& what) {
  throw std::invalid_argument(std::string(name) + ": " + what);
}

json parse(std::string_view text, std::string_view name) {
  json doc = json::parse(text.begin(), text.end(), nullptr, false);
  if (doc.is_discarded()) fail(name, "not JSON");
  if (!doc.is_object()) fail(name, "not a JSON object");
  return doc;
}

double number(const json& object, const char* key, std::string_view name, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end()) fail(name, where + "'" + key + "' is missing");
  if (!it->is_number()) fail(name, where + "'" + key + "' is not a number");
  const double value = it->get<double>();
  if (!std::isfinite(value)) fail(name, where + "'" + key + "' is not finite");
  return value;
}

double number_or(const json& object, const char* key, double fallback, std::string_view name) {
  return object.contains(key) ? number(object, key, name, "") : fallback;
}

bool flag(const json& object, const char* key, std::string_view name, const std::string& where) {
  const auto it = object.find(key);
  if (it == object.end()) fail(name, where + "'" + key + "' is missing");
  if (it->is_boolean()) return it->get<bool>();
  if (it->is_number()) return it->get<double>() > 0.5;  // bam/process.py interpolates it
  fail(name, where + "'" + key + "' is neither a boolean nor a number");
}

std::string text_or_empty(const json& object, const char* key) {
  const auto it = object.find(key);
  return it != object.end() && it->is_string() ? it->get<std::string>() : std::string();
}

bool protocol2(std::string_view servo) {
  return dynamixel::servo_spec(servo).family == dynamixel::ServoFamily::kNone;
}

// The pendulum as BAM's Pendulum testbench has it: an end mass and a uniform arm, the arm
// hanging down at 0; inertia about the axis m l^2 + m_arm l^2 / 3 (+ the armature).
std::string pendulum_robot(const PendulumLog& log, const ReplayOptions& options, double armature_kg_m2) {
  const double mass = log.mass_kg + log.arm_mass_kg;
  const double com = (log.mass_kg * log.length_m + log.arm_mass_kg * log.length_m / 2.0) / mass;
  const double about_axis =
      log.mass_kg * log.length_m * log.length_m + log.arm_mass_kg * log.length_m * log.length_m / 3.0 + armature_kg_m2;
  // About the centre of mass, the same for every axis (only the joint's counts). A point mass alone
  // has none, which the engines' iterative solvers do not hold still against friction; a real end
  // mass is no point (a 0.5 kg disc of 2.5 cm radius at 0.15 m has 1.4 % of the pendulum's inertia
  // about its own centre): at least 2 % of the inertia about the axis, added to it.
  const double point = about_axis - mass * com * com;
  const double central = std::max(point, 0.02 * about_axis);
  const std::string c = std::to_string(central);
  const double initial_deg = log.samples.front().position_rad * 180.0 / std::numbers::pi;
  return "name: \"bam-pendulum\"\n"
         "bus { name: \"b\" baud_bps: 1000000 protocol: " +
         std::string(protocol2(options.servo) ? "PROTOCOL_2" : "PROTOCOL_1") +
         " supply_voltage_v: " + std::to_string(log.vin_v) + " device { id: 1 model: \"" + options.servo +
         "\" name: \"J\" } }\n"
         "figure {\n"
         "  motor_friction: " +
         (options.bam_model == 0 ? std::string("FRICTION_DEFAULT") : "FRICTION_BAM_M" + std::to_string(options.bam_model)) +
         "\n"
         "  body { name: \"base\" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.8 y: 0.8 z: 0.1 } } } mass_kg: 100 }\n"
         "  body { name: \"post\" pose { position_m { z: 0.5 } } shape { box { size_m { x: 0.04 y: 0.04 z: 0.8 } } } mass_kg: 1 }\n"
         "  body { name: \"pendulum\" pose { position_m { z: 1.0 } } inertial { mass_kg: " +
         std::to_string(mass) + " origin { position_m { z: " + std::to_string(-com) + " } } ixx_kg_m2: " + c +
         " iyy_kg_m2: " + c + " izz_kg_m2: " + c +
         " } }\n"
         "  link { name: \"fix\" type: LINK_FIXED parent: \"base\" child: \"post\" }\n"
         "  link { name: \"J\" type: LINK_REVOLUTE parent: \"post\" child: \"pendulum\" anchor_m { z: 1.0 } axis { y: 1 }\n"
         "         initial_deg: " +
         std::to_string(initial_deg) + " motor { bus: 0 id: 1 } }\n}\n";
}

// The P Gain register `kp` of the servo's firmware: MX (Protocol 1.0) P Gain 0..254, X / MX(2.0)
// Position P Gain 0..16383.
dynamixel::PidGains gains(std::string_view servo, double kp) {
  const auto raw = static_cast<uint16_t>(std::lround(kp));
  if (dynamixel::servo_spec(servo).family == dynamixel::ServoFamily::kMx) {
    if (raw > 254) throw std::invalid_argument("P Gain " + std::to_string(raw) + " is beyond an MX's 254");
    return dynamixel::mx_pid_gains(static_cast<uint8_t>(raw), 0, 0);
  }
  return dynamixel::x_pid_gains(raw, 0, 0);
}

dynamixel::ServoCommand command_for(std::string_view servo, double kp) {
  dynamixel::ServoCommand command;
  command.pid = gains(servo, kp);
  command.min_position_rad = -std::numbers::pi;
  command.max_position_rad = std::numbers::pi;
  return command;
}

}  // namespace

PendulumLog parse_bam_log(std::string_view json_text, std::string_view name) {
  const json doc = parse(json_text, name);
  PendulumLog log;
  log.name = std::string(name);
  log.motor = text_or_empty(doc, "motor");
  log.trajectory = text_or_empty(doc, "trajectory");
  log.mass_kg = number(doc, "mass", name, "");
  log.arm_mass_kg = doc.contains("arm_mass") ? number(doc, "arm_mass", name, "") : number_or(doc, "arm-mass", 0.0, name);
  log.length_m = number(doc, "length", name, "");
  log.kp = number(doc, "kp", name, "");
  log.vin_v = number_or(doc, "vin", 15.0, name);
  if (!(log.mass_kg >= 0.0 && log.arm_mass_kg >= 0.0 && log.mass_kg + log.arm_mass_kg > 0.0)) {
    fail(name, "'mass' and 'arm_mass' must be >= 0 and not both 0");
  }
  if (!(log.length_m > 0.0 && log.length_m < 2.0)) fail(name, "'length' must be in (0, 2) m");
  if (!(log.kp >= 0.0 && log.kp <= 16383.0)) fail(name, "'kp' must be a P Gain register value (MX 0..254, X 0..16383)");
  if (!(log.vin_v > 0.0 && log.vin_v <= 30.0)) fail(name, "'vin' must be in (0, 30] V");
  const auto entries = doc.find("entries");
  if (entries == doc.end() || !entries->is_array()) fail(name, "'entries' is missing or not an array");
  if (entries->size() < 2) fail(name, "'entries' needs at least two samples");
  const bool stamped = (*entries)[0].is_object() && (*entries)[0].contains("timestamp");
  const double dt = stamped ? 0.0 : number(doc, "dt", name, "entries without 'timestamp': ");
  if (!stamped && !(dt > 0.0)) fail(name, "'dt' must be > 0");
  log.samples.reserve(entries->size());
  for (std::size_t i = 0; i < entries->size(); ++i) {
    const json& e = (*entries)[i];
    const std::string where = "entries[" + std::to_string(i) + "]: ";
    if (!e.is_object()) fail(name, where + "not an object");
    PendulumSample s;
    s.time_s = stamped ? number(e, "timestamp", name, where) : static_cast<double>(i) * dt;
    s.position_rad = number(e, "position", name, where);
    s.goal_position_rad = number(e, "goal_position", name, where);
    s.torque_enable = flag(e, "torque_enable", name, where);
    if (!log.samples.empty() && !(s.time_s > log.samples.back().time_s)) {
      fail(name, where + "'timestamp' does not increase");
    }
    log.samples.push_back(s);
  }
  return log;
}

ReplayResult replay_bam_log(const PendulumLog& log, const ReplayOptions& options,
                            std::unique_ptr<physics::Backend> backend) {
  if (log.samples.size() < 2) throw std::invalid_argument(log.name + ": needs at least two samples");
  if (!(options.step_s > 0.0 && options.step_s <= 0.01)) throw std::invalid_argument("step must be in (0, 10] ms");
  const physics::DcMotorParams motor = motor_params(options.servo, options.bam_model);
  const double armature = options.armature ? motor.armature_kg_m2 : 0.0;
  physics::RobotModel robot = physics::compile_robot(
      proto::RobotFile::parse(pendulum_robot(log, options, armature), log.name + " (pendulum)"), motor_catalog());

  physics::WorldOptions world_options;
  world_options.step_s = options.step_s;
  world_options.ball.present = false;
  world_options.hold = physics::HoldMode::kReleased;
  world_options.supply_voltage_v = log.vin_v;
  std::vector<physics::RobotModel> robots;
  robots.push_back(std::move(robot));
  physics::World world(std::move(backend), std::move(robots), {}, world_options);
  PhysicsBody body(world, 0);
  body.add_servo(0, 1, ServoSetup{dynamixel::servo_controller_config(options.servo), 0.0, log.vin_v});
  const physics::MotorHandle handle = *body.motor(0);

  dynamixel::ServoCommand command = command_for(options.servo, log.kp);
  ReplayResult result;
  result.simulated_rad.reserve(log.samples.size());
  const double t0 = log.samples.front().time_s;
  std::size_t current = 0;  // the latest sample whose time has come: its goal and torque enable act
  double squares = 0.0;
  double absolute = 0.0;
  for (std::size_t i = 0; i < log.samples.size(); ++i) {
    const double due = log.samples[i].time_s - t0;
    while (static_cast<double>(world.time_ns()) * 1e-9 < due - 0.5 * options.step_s) {
      const double now = static_cast<double>(world.time_ns()) * 1e-9;
      while (current + 1 < log.samples.size() && log.samples[current + 1].time_s - t0 <= now) ++current;
      command.torque_enabled = log.samples[current].torque_enable;
      command.goal_position_rad =
          std::clamp(log.samples[current].goal_position_rad, command.min_position_rad, command.max_position_rad);
      body.drive(0, command, options.step_s);
      world.step();
    }
    const double simulated = world.motor(handle).position_rad;
    const double error = std::abs(simulated - log.samples[i].position_rad);
    result.simulated_rad.push_back(simulated);
    absolute += error;
    squares += error * error;
    result.max_error_rad = std::max(result.max_error_rad, error);
  }
  result.samples = log.samples.size();
  result.mae_rad = absolute / static_cast<double>(result.samples);
  result.rmse_rad = std::sqrt(squares / static_cast<double>(result.samples));
  return result;
}

std::vector<SpeedPoint> parse_speed_table(std::string_view json_text, std::string_view name) {
  const json doc = parse(json_text, name);
  std::vector<SpeedPoint> points;
  for (const auto& [key, value] : doc.items()) {
    SpeedPoint p;
    try {
      std::size_t used = 0;
      p.volts = std::stod(key, &used);
      if (used != key.size()) throw std::invalid_argument(key);
    } catch (const std::exception&) {
      fail(name, "key '" + key + "' is not a voltage");
    }
    if (!value.is_number()) fail(name, "'" + key + "' is not a number");
    p.measured_rad_s = value.get<double>();
    if (!(std::isfinite(p.volts) && std::isfinite(p.measured_rad_s))) fail(name, "'" + key + "' is not finite");
    points.push_back(p);
  }
  if (points.empty()) fail(name, "no voltage");
  std::sort(points.begin(), points.end(), [](const SpeedPoint& a, const SpeedPoint& b) { return a.volts < b.volts; });
  return points;
}

std::vector<DutyPoint> parse_duty_table(std::string_view json_text, std::string_view name) {
  const json doc = parse(json_text, name);
  const double period = number(doc, "pwm_period", name, "");
  if (!(period > 0.0)) fail(name, "'pwm_period' must be > 0");
  const auto samples = doc.find("samples");
  if (samples == doc.end() || !samples->is_array() || samples->empty()) fail(name, "'samples' is missing or empty");
  std::vector<DutyPoint> points;
  for (std::size_t i = 0; i < samples->size(); ++i) {
    const json& s = (*samples)[i];
    const std::string where = "samples[" + std::to_string(i) + "]: ";
    if (!s.is_object()) fail(name, where + "not an object");
    DutyPoint p;
    p.error_rad = std::abs(number(s, "position", name, where) - number(s, "target", name, where)) * std::numbers::pi / 180.0;
    p.kp = number(s, "kp", name, where);
    p.measured_duty = number(s, "period", name, where) / period;
    if (!(p.kp >= 0.0 && p.kp <= 254.0)) fail(name, where + "'kp' must be 0..254");
    points.push_back(p);
  }
  return points;
}

double doppel_no_load_speed_rad_s(std::string_view servo, int bam_model, double volts) {
  return physics::no_load_speed_rad_s(motor_params(servo, bam_model), volts);
}

double doppel_duty(std::string_view servo, double kp, double error_rad) {
  dynamixel::ServoController controller(dynamixel::servo_controller_config(servo));
  controller.reset(0.0);
  dynamixel::ServoCommand command = command_for(servo, kp);
  command.torque_enabled = true;
  command.goal_position_rad = error_rad;
  return std::abs(controller.update(command, 0.0, 0.0, 0.001, 15.0).pwm_ratio);
}

}  // namespace doppel::body
