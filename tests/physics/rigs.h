#pragma once
// Small robots and helpers for the physics tests: test rigs written as Robot Description Files,
// worlds on a chosen engine, and a firmware loop that drives every servo of a robot the way the
// gateway does (ServoCommand -> ServoController -> MotorCommand).

#include <memory>
#include <string>
#include <vector>

#include "body/motor_params.h"
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

// The gateway's job for the tests: every servo of robot 0 follows its ServoCommand through the
// firmware controller.
class Firmware {
 public:
  Firmware(World& world, size_t robot) : world_(world) {
    const RobotModel& model = world.robot(robot);
    for (const MotorModel& m : model.motors) {
      Servo servo{*world.find_motor(robot, m.bus, m.id), dynamixel::ServoController(dynamixel::servo_controller_config(m.model)),
                  dynamixel::ServoCommand{}, m.link};
      servo.command.torque_enabled = false;
      servo.command.goal_position_rad = world.motor(servo.handle).position_rad;
      servo.command.cw_compliance_margin_raw = 1;
      servo.command.ccw_compliance_margin_raw = 1;
      servo.command.cw_compliance_slope_raw = 32;
      servo.command.ccw_compliance_slope_raw = 32;
      servo.command.punch_raw = 32;
      servo.command.pid = dynamixel::mx_pid_gains(32, 0, 0);
      servo.command.min_position_rad = -2.6;
      servo.command.max_position_rad = 2.6;
      servos_.push_back(servo);
    }
  }

  // Torque on for every servo, goals = present positions (what a driver does at start).
  void enable_all() {
    for (Servo& s : servos_) {
      s.command.torque_enabled = true;
      s.command.goal_position_rad = world_.motor(s.handle).position_rad;
    }
  }
  void disable_all() {
    for (Servo& s : servos_) s.command.torque_enabled = false;
  }
  dynamixel::ServoCommand& command(size_t i) { return servos_[i].command; }
  size_t size() const { return servos_.size(); }
  MotorHandle handle(size_t i) const { return servos_[i].handle; }
  int link(size_t i) const { return servos_[i].link; }

  // One gateway tick: firmware, then physics.
  void step() {
    for (Servo& s : servos_) {
      const MotorState state = world_.motor(s.handle);
      const dynamixel::ControllerOutput out =
          s.controller.update(s.command, state.position_rad, state.velocity_rad_s, world_.options().step_s,
                              state.voltage_v);
      world_.set_motor(s.handle, MotorCommand{s.command.torque_enabled, out.pwm_ratio, s.command.torque_limit_ratio});
    }
    world_.step();
  }
  void run(double seconds) {
    const auto n = static_cast<long>(seconds / world_.options().step_s + 0.5);
    for (long i = 0; i < n; ++i) step();
  }

 private:
  struct Servo {
    MotorHandle handle;
    dynamixel::ServoController controller;
    dynamixel::ServoCommand command;
    int link;
  };
  World& world_;
  std::vector<Servo> servos_;
};

}  // namespace doppel::physics::test
