// Steps per second of the physics world at a 1 ms step: one robot, and six robots (3 vs 3) on the
// 2011 KidSize field with the ball, on each engine. Every servo runs the firmware controller with
// torque on, holding the robot's standing pose, as the gateway does each tick; the figure is thus
// the cost of one gateway tick's simulation. Counter "rtf" is the real-time factor (simulated
// seconds per CPU second). "iterations" are constraint-solver sweeps (default 10), "self_collision"
// the robots' Figure.self_collision (default on). Run: physics_bench --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <string>
#include <vector>

#include "body/motor_params.h"
#include "dynamixel/servo_controller.h"
#include "physics/engines.h"
#include "physics/field.h"
#include "physics/world.h"

namespace {

using namespace doppel::physics;

RobotModel robot() {
  static const RobotModel model =
      compile_robot(doppel::proto::RobotFile::load(std::string(DOPPEL_ROBOTS_DIR) + "/fumanoid-2011.textproto"),
                    doppel::body::motor_catalog());
  return model;
}

void BM_WorldStep(benchmark::State& state) {
  const std::string engine = engine_names()[static_cast<size_t>(state.range(0))];
  const auto robots = static_cast<size_t>(state.range(1));
  WorldOptions options;
  options.solver_iterations = static_cast<int>(state.range(2));
  options.field = field_shapes();
  RobotModel model = robot();
  model.self_collision = state.range(3) != 0;
  std::vector<RobotModel> models(robots, model);
  std::vector<RobotPlacement> placements;
  for (size_t r = 0; r < robots; ++r) {
    const double side = r % 2 == 0 ? -1.0 : 1.0;
    placements.push_back(RobotPlacement{Eigen::Vector3d(side * 1.0, (static_cast<double>(r / 2) - 1.0) * 1.0, 0.0),
                                        side > 0 ? 3.14159 : 0.0, static_cast<uint8_t>(r % 2)});
  }
  World world(make_backend(engine_from_name(engine)), std::move(models), std::move(placements), options);

  struct Servo {
    MotorHandle handle;
    doppel::dynamixel::ServoController controller;
    doppel::dynamixel::ServoCommand command;
  };
  std::vector<Servo> servos;
  for (size_t r = 0; r < robots; ++r) {
    for (const MotorModel& m : world.robot(r).motors) {
      Servo s{*world.find_motor(r, m.bus, m.id),
              doppel::dynamixel::ServoController(doppel::dynamixel::servo_controller_config(m.model)), {}};
      s.command.torque_enabled = true;
      s.command.goal_position_rad = world.motor(s.handle).position_rad;
      s.command.cw_compliance_margin_raw = s.command.ccw_compliance_margin_raw = 1;
      s.command.cw_compliance_slope_raw = s.command.ccw_compliance_slope_raw = 32;
      s.command.punch_raw = 32;
      servos.push_back(s);
    }
  }
  auto tick = [&] {
    for (Servo& s : servos) {
      const MotorState m = world.motor(s.handle);
      const auto out = s.controller.update(s.command, m.position_rad, m.velocity_rad_s, options.step_s);
      world.set_motor(s.handle, MotorCommand{true, out.pwm_ratio, 1.0});
    }
    world.step();
  };
  for (int i = 0; i < 200; ++i) tick();  // released and settled on the carpet

  for (auto _ : state) tick();

  state.SetItemsProcessed(state.iterations());  // items = steps
  state.counters["rtf"] = benchmark::Counter(static_cast<double>(state.iterations()) * options.step_s,
                                             benchmark::Counter::kIsRate);
  state.SetLabel(engine);
}

BENCHMARK(BM_WorldStep)
    ->ArgNames({"engine", "robots", "iterations", "self_collision"})
    ->ArgsProduct({{0, 1}, {1, 6}, {10}, {1, 0}})
    ->ArgsProduct({{0, 1}, {1, 6}, {20}, {1}});

}  // namespace
