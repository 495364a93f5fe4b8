// The scenario's step observer on the simulation thread: after setup it applies pushes and ball
// moves and accumulates the metrics without allocating (a replaced global operator new counts),
// and its schedule puts every entry on the whole step at or after its time, with the time spreads
// drawn from the seed. Its own executable, because it replaces the global operator new.
#include <gtest/gtest.h>

#include <set>

#include "allocation_counter.h"
#include "observer.h"
#include "physics/engines.h"
#include "physics/field.h"

namespace doppel::scenario {
namespace {

const std::string kRobots = DOPPEL_ROBOTS_DIR;

TEST(ScenarioObserver, AppliesTheScheduleAndMeasuresWithoutAllocating) {
  const Scenario scenario = parse_scenario(R"(name: "a" duration_s: 0.4
    robot { name: "fumanoid-2011" }
    push { time_s: 0.05 fy_n: 200 duration_s: 0.05 }
    ball { time_s: 0.1 x_m: 1 y_m: 1 vx_m_s: 1 })", "/t/a.textproto", kRobots);
  physics::WorldOptions options;
  options.hold = physics::HoldMode::kReleased;
  options.field = physics::field_shapes();
  physics::World world(physics::make_backend(physics::Engine::kOde), {*scenario.robots[0].config.body}, {}, options);
  std::vector<std::vector<physics::MotorHandle>> motors(1);
  for (std::size_t b = 0; b < scenario.robots[0].config.buses.size(); ++b) {
    for (const auto& device : scenario.robots[0].config.buses[b].devices) {
      if (auto motor = world.find_motor(0, static_cast<uint32_t>(b), device.id)) motors[0].push_back(*motor);
    }
  }
  ASSERT_FALSE(motors[0].empty());
  ScenarioObserver observer(scenario, schedule(scenario, 0), 400'000'000, std::move(motors));
  for (int step = 0; step < 500 && !observer.done(); ++step) {
    world.step();
    doppel::testing::count_allocations_on_this_thread(true);
    observer.after_step(world, world.time_ns());
    doppel::testing::count_allocations_on_this_thread(false);
  }
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u);
  ASSERT_TRUE(observer.done());
  EXPECT_EQ(observer.sim_time_ns(), 400'000'000);
  EXPECT_EQ(observer.applied_ns()[0], 50'000'000);
  EXPECT_EQ(observer.applied_ns()[1], 100'000'000);
  EXPECT_GT(observer.ball().x(), 1.1) << "rolling along +x since 0.1 s";
  EXPECT_GT(observer.tracks()[0].metrics().lateral_m, 0.01) << "200 N x 50 ms along +y moved the limp robot";
}

Scenario spread_scenario() {
  return parse_scenario(R"(name: "s" duration_s: 10
    robot { name: "fumanoid-2011" }
    push { time_s: 2 duration_s: 0.1 time_spread_s: 1 }
    push { time_s: 0.0004 duration_s: 0.1 }
    ball { time_s: 1 time_spread_s: 0.5 })", "/t/s.textproto", kRobots);
}

TEST(ScenarioSchedule, EntriesFallOnWholeStepsInTimeOrder) {
  const std::vector<Event> events = schedule(spread_scenario(), 1);
  ASSERT_EQ(events.size(), 3u);
  EXPECT_EQ(events[0].at_ns, 1'000'000) << "0.4 ms: the first step that starts at or after it";
  EXPECT_TRUE(events[0].push);
  EXPECT_EQ(events[0].index, 1u);
  EXPECT_FALSE(events[1].push);
  EXPECT_GE(events[1].at_ns, 1'000'000'000);
  EXPECT_LE(events[1].at_ns, 1'500'000'000);
  EXPECT_GE(events[2].at_ns, 2'000'000'000);
  EXPECT_LE(events[2].at_ns, 3'000'000'000);
  for (const Event& event : events) EXPECT_EQ(event.at_ns % kStepNs, 0);
}

TEST(ScenarioSchedule, TheSameSeedGivesTheSameTimesAndSeedsVaryThem) {
  const Scenario scenario = spread_scenario();
  const auto times = [&](uint64_t seed) {
    std::vector<int64_t> out;
    for (const Event& event : schedule(scenario, seed)) out.push_back(event.at_ns);
    return out;
  };
  EXPECT_EQ(times(7), times(7));
  std::set<std::vector<int64_t>> seen;
  for (uint64_t seed = 0; seed < 10; ++seed) seen.insert(times(seed));
  EXPECT_GE(seen.size(), 9u) << "10 seeds, times drawn from 1000 and 500 steps";
}

}  // namespace
}  // namespace doppel::scenario
