#pragma once
// Small robots and helpers for the physics tests: test rigs written as Robot Description Files,
// worlds on a chosen engine, and a robot whose servos run the gateway's drive loop (body/).

#include <memory>
#include <string>
#include <vector>

#include "body/motor_params.h"
#include "body/physics_body.h"
#include "dynamixel/servo_controller.h"
#include "physics/engines.h"
#include "physics/robot_model.h"
#include "physics/world.h"

namespace doppel::physics::test {

inline std::string robots_dir() { return DOPPEL_ROBOTS_DIR; }

inline RobotModel robot_from_text(const std::string& text) {
  return compile_robot(proto::RobotFile::parse(text, "rig.textproto"), doppel::body::motor_catalog());
}

inline RobotModel shipped_robot(const std::string& name) {
  return compile_robot(proto::RobotFile::load(robots_dir() + "/" + name + ".textproto"), doppel::body::motor_catalog());
}

inline WorldOptions bare_options() {
  WorldOptions o;
  o.ball.present = false;
  return o;
}

inline std::unique_ptr<World> make_world(const std::string& engine, std::vector<RobotModel> robots,
                                         WorldOptions options = bare_options(),
                                         std::vector<RobotPlacement> placements = {}) {
  return std::make_unique<World>(make_backend(engine_from_name(engine)), std::move(robots), std::move(placements), std::move(options));
}

// One RX-64 turning a rotor about the vertical axis on a heavy base resting on the floor
// (the base is the root; gravity does not load the motor). `rotor` is the rotor's shape and mass.
inline std::string servo_rig(const std::string& rotor, const std::string& motor_extra = "") {
  return R"(name: "servo-rig"
bus { name: "b" baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: "RX-64" name: "J" } }
figure {
  material { name: "grip" friction: 1.0 }
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.6 y: 0.6 z: 0.1 } } }
         mass_kg: 80 material: "grip" }
  body { name: "rotor" pose { position_m { z: 0.2 } } )" +
         rotor + R"( }
  link { name: "J" type: LINK_REVOLUTE parent: "base" child: "rotor" anchor_m { z: 0.1 } axis { z: 1 }
         motor { bus: 0 id: 1 )" +
         motor_extra + R"( } }
})";
}

// An arm on a post turning about y between mechanical stops at -10 and +20 deg, driven by servo
// ID 1 of the one bus `bus` declares (e.g. `baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1
// model: "RX-64" name: "J" }`): a goal behind a stop stalls the motor against it.
inline std::string stall_rig(const std::string& bus) {
  return R"(name: "stall"
bus { name: "b" )" + bus + R"( }
figure {
  body { name: "base" pose { position_m { z: 0.05 } } shape { box { size_m { x: 0.8 y: 0.8 z: 0.1 } } } mass_kg: 100 }
  body { name: "post" pose { position_m { z: 0.35 } } shape { box { size_m { x: 0.04 y: 0.04 z: 0.5 } } } mass_kg: 1 }
  body { name: "arm" pose { position_m { y: 0.05 z: 0.4 } } shape { box { size_m { x: 0.02 y: 0.02 z: 0.2 } } } mass_kg: 0.2 }
  link { name: "fix" type: LINK_FIXED parent: "base" child: "post" }
  link { name: "J" type: LINK_REVOLUTE parent: "post" child: "arm" anchor_m { y: 0.05 z: 0.5 } axis { y: 1 }
         lower_deg: -10 upper_deg: 20 motor { bus: 0 id: 1 } }
})";
}

// Robot `robot`'s servos driven through the gateway's drive loop (body::PhysicsBody), with the
// registers a driver writes at start (compliance 1/1/32/32, punch 32, MX PID P 32, limits
// +-2.6 rad) in place of the bus: the tests set the commands, the body does the rest.
class DrivenRobot {
 public:
  DrivenRobot(World& world, size_t robot) : world_(world), body_(world, robot) {
    for (const MotorModel& m : world.robot(robot).motors) {
      body_.add_servo(m.bus, m.id, body::ServoSetup{dynamixel::servo_controller_config(m.model), 0.0, 0.0});
      dynamixel::ServoCommand& command = commands_.emplace_back();
      command.goal_position_rad = world.motor(*world.find_motor(robot, m.bus, m.id)).position_rad;
      command.cw_compliance_margin_raw = 1;
      command.ccw_compliance_margin_raw = 1;
      command.cw_compliance_slope_raw = 32;
      command.ccw_compliance_slope_raw = 32;
      command.punch_raw = 32;
      command.pid = dynamixel::mx_pid_gains(32, 0, 0);
      command.min_position_rad = -2.6;
      command.max_position_rad = 2.6;
      links_.push_back(m.link);
    }
    feedback_.resize(commands_.size());
  }

  // Torque on for every servo, goals = present positions (what a driver does at start).
  void enable_all() {
    for (size_t i = 0; i < size(); ++i) {
      commands_[i].torque_enabled = true;
      commands_[i].goal_position_rad = world_.motor(handle(i)).position_rad;
    }
  }
  void disable_all() {
    for (dynamixel::ServoCommand& command : commands_) command.torque_enabled = false;
  }
  dynamixel::ServoCommand& command(size_t i) { return commands_[i]; }
  // What servo i measured after the last step().
  const dynamixel::ServoFeedback& feedback(size_t i) const { return feedback_[i]; }
  size_t size() const { return commands_.size(); }
  MotorHandle handle(size_t i) const { return *body_.motor(i); }
  int link(size_t i) const { return links_[i]; }
  const body::PhysicsBody& body() const { return body_; }

  // One gateway tick: drive, step, sense.
  void step() {
    drive();
    world_.step();
    sense();
  }
  // The halves around the world's step, for several driven robots in one world.
  void drive() {
    for (size_t i = 0; i < size(); ++i) body_.drive(i, commands_[i], world_.options().step_s);
  }
  void sense() {
    for (size_t i = 0; i < size(); ++i) feedback_[i] = body_.servo(i, world_.time_ns());
  }
  void run(double seconds) {
    const auto n = static_cast<long>(seconds / world_.options().step_s + 0.5);
    for (long i = 0; i < n; ++i) step();
  }

 private:
  World& world_;
  body::PhysicsBody body_;
  std::vector<dynamixel::ServoCommand> commands_;
  std::vector<dynamixel::ServoFeedback> feedback_;
  std::vector<int> links_;
};

}  // namespace doppel::physics::test
