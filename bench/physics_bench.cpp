// Steps per second of the physics world at a 1 ms step: one robot, and six robots (3 vs 3) on the
// 2011 KidSize field with the ball, on each engine. Every servo runs the firmware controller with
// torque on, holding the robot's standing pose, as the gateway does each tick; the figure is thus
// the cost of one gateway tick's simulation. Counter "rtf" is the real-time factor (simulated
// seconds per CPU second). "iterations" are constraint-solver sweeps (default 10), "self_collision"
// the robots' Figure.self_collision (default on). Run: physics_bench --benchmark_min_time=2
#include <benchmark/benchmark.h>

#include <memory>
#include <string>
#include <vector>

#include "body/motor_params.h"
#include "body/physics_body.h"
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

  // Each robot's servos through the gateway's drive loop (body::PhysicsBody).
  std::vector<std::unique_ptr<doppel::body::PhysicsBody>> bodies;
  std::vector<doppel::dynamixel::ServoCommand> commands;
  for (size_t r = 0; r < robots; ++r) {
    auto& body = bodies.emplace_back(std::make_unique<doppel::body::PhysicsBody>(world, r));
    for (const MotorModel& m : world.robot(r).motors) {
      body->add_servo(m.bus, m.id, doppel::body::ServoSetup{doppel::dynamixel::servo_controller_config(m.model)});
      doppel::dynamixel::ServoCommand& c = commands.emplace_back();
      c.torque_enabled = true;
      c.goal_position_rad = world.motor(*world.find_motor(r, m.bus, m.id)).position_rad;
      c.cw_compliance_margin_raw = c.ccw_compliance_margin_raw = 1;
      c.cw_compliance_slope_raw = c.ccw_compliance_slope_raw = 32;
      c.punch_raw = 32;
    }
  }
  const size_t servos = world.robot(0).motors.size();  // every robot is the same model
  auto tick = [&] {
    for (size_t r = 0; r < robots; ++r) {
      for (size_t s = 0; s < servos; ++s) bodies[r]->drive(s, commands[r * servos + s], options.step_s);
    }
    world.step();
    for (size_t r = 0; r < robots; ++r) {
      for (size_t s = 0; s < servos; ++s) benchmark::DoNotOptimize(bodies[r]->servo(s, world.time_ns()));
    }
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
