// Scenario files (libs/proto/scenario.proto): the shipped one loads, and every kind of bad input is
// refused with a message naming file, line and field before anything runs.
#include <gtest/gtest.h>

#include <filesystem>
#include <stdexcept>
#include <string>

#include "scenario/scenario.h"

namespace doppel::scenario {
namespace {

const std::string kRobots = DOPPEL_SOURCE_ROBOTS_DIR;
const std::string kHead = "name: \"t\"\nduration_s: 2\nrobot { name: \"fumanoid-2011\" }\n";

Scenario parse(const std::string& text) { return parse_scenario(text, "/some/dir/s.textproto", kRobots); }

// The message of the exception parsing `text` throws (fails the test when none is thrown).
std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const std::exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error for:\n" << text;
  return "";
}

TEST(ScenarioFile, TheShippedWalkForwardLoads) {
  const Scenario s = load_scenario(DOPPEL_SOURCE_SCENARIOS_DIR "/walk-forward.textproto", kRobots);
  EXPECT_EQ(s.name, "walk-forward");
  EXPECT_EQ(s.duration_s, 20.0);
  ASSERT_EQ(s.robots.size(), 1u);
  EXPECT_EQ(s.robots[0].config.name, "fumanoid-2011");
  ASSERT_EQ(s.controllers.size(), 1u);
  EXPECT_EQ(s.controllers[0].argv[0], "doppel-walk");
  EXPECT_EQ(s.params.at("speed"), "0.05");
  EXPECT_EQ(s.params.at("period"), "0.5");
  EXPECT_TRUE(s.metrics.distance && s.metrics.energy && s.metrics.control_cycle) << "no metrics block: all of them";
}

TEST(ScenarioFile, EveryShippedScenarioLoads) {
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(DOPPEL_SOURCE_SCENARIOS_DIR)) {
    if (entry.path().extension() != ".textproto") continue;
    ++files;
    EXPECT_NO_THROW(load_scenario(entry.path().string(), kRobots)) << entry.path();
  }
  EXPECT_GE(files, 2);
}

TEST(ScenarioFile, AFullFileKeepsEverything) {
  const Scenario s = parse(kHead + R"(
    push { time_s: 0.5 robot: 0 fy_n: 30 duration_s: 0.1 time_spread_s: 0.2 }
    ball { time_s: 1 x_m: 1 y_m: -0.5 vx_m_s: 2 }
    fault { kind: "corrupt" robot: 0 bus: 0 time_s: 1 duration_s: 0.3 rate: 0.01 seed: 4 }
    fault { kind: "brownout" time_s: 1.5 value: 9 }
    param { name: "speed" value: "0.1" }
    controller { argv: "prog" argv: "--port={link:0}" argv: "{param:speed}" doppel_run: true }
    metrics { energy: true peak_tilt: true }
    physics: "bullet" seed: 7
    robot { name: "darwin-op" start { x_m: 1 y_m: 2 yaw_deg: 90 } })");
  ASSERT_EQ(s.robots.size(), 2u);
  ASSERT_TRUE(s.robots[1].start.has_value());
  EXPECT_NEAR(s.robots[1].start->yaw_rad, 1.5707963267948966, 1e-12);
  ASSERT_EQ(s.pushes.size(), 1u);
  EXPECT_EQ(s.pushes[0].steps, 100u);
  EXPECT_EQ(s.pushes[0].fy_n, 30.0);
  EXPECT_EQ(s.pushes[0].time_spread_s, 0.2);
  EXPECT_NE(s.pushes[0].location.find("/some/dir/s.textproto:5:"), std::string::npos) << s.pushes[0].location;
  ASSERT_EQ(s.balls.size(), 1u);
  EXPECT_EQ(s.balls[0].vx_m_s, 2.0);
  ASSERT_EQ(s.faults.size(), 2u);
  EXPECT_EQ(s.faults[0].spec.kind, faults::FaultKind::kCorrupt);
  EXPECT_EQ(s.faults[0].spec.bus, 0);
  EXPECT_EQ(s.faults[0].spec.id, -1);
  EXPECT_EQ(s.faults[0].spec.start_ns, 1'000'000'000);
  EXPECT_EQ(s.faults[0].spec.duration_ns, 300'000'000);
  EXPECT_EQ(s.faults[0].spec.rate, 0.01);
  EXPECT_EQ(s.faults[0].spec.seed, 4u);
  EXPECT_FALSE(s.faults[0].seed_from_run);
  EXPECT_EQ(s.faults[1].spec.kind, faults::FaultKind::kBrownout);
  EXPECT_EQ(s.faults[1].spec.bus, -1);
  EXPECT_EQ(s.faults[1].spec.value, 9.0);
  EXPECT_EQ(s.faults[1].spec.duration_ns, faults::kForever);
  EXPECT_TRUE(s.faults[1].seed_from_run);
  EXPECT_TRUE(s.controllers[0].doppel_run);
  EXPECT_TRUE(s.metrics.energy && s.metrics.peak_tilt);
  EXPECT_FALSE(s.metrics.distance || s.metrics.time_to_fall || s.metrics.control_cycle);
  EXPECT_EQ(s.engine, physics::Engine::kBullet);
  EXPECT_EQ(s.seed, 7u);
  EXPECT_EQ(s.folder, "/some/dir");
}

struct BadCase {
  const char* what;
  std::string text;
  std::string expected;  // part of the message: the location and the field
};

class ScenarioFileRefuses : public ::testing::TestWithParam<BadCase> {};

TEST_P(ScenarioFileRefuses, NamingFileLineAndField) {
  const std::string message = error_of(GetParam().text);
  EXPECT_NE(message.find(GetParam().expected), std::string::npos) << GetParam().what << ": " << message;
}

INSTANTIATE_TEST_SUITE_P(
    BadInput, ScenarioFileRefuses,
    ::testing::Values(
        BadCase{"syntax", kHead + "push { time_s: }\n", "s.textproto:4:"},
        BadCase{"unknown field", kHead + "speed: 3\n", "s.textproto:4:6: Message type \"doppel.proto.Scenario\" has no field named \"speed\""},
        BadCase{"no name", "duration_s: 1\nrobot { name: \"fumanoid-2011\" }\n", "s.textproto:1:1: Scenario.name: missing scenario name"},
        BadCase{"bad name", "name: \"a b\"\nduration_s: 1\nrobot { name: \"fumanoid-2011\" }\n", "s.textproto:1:1: Scenario.name: use letters"},
        BadCase{"no duration", "name: \"t\"\nrobot { name: \"fumanoid-2011\" }\n", "Scenario.duration_s"},
        BadCase{"negative duration", "name: \"t\"\nduration_s: -1\nrobot { name: \"fumanoid-2011\" }\n", "s.textproto:2:1: Scenario.duration_s: must be > 0"},
        BadCase{"no robot", "name: \"t\"\nduration_s: 1\n", "Scenario.robot: a scenario needs at least one robot"},
        BadCase{"robot name and file", kHead + "robot { name: \"op3\" file: \"x\" }\n", "s.textproto:4:1: Scenario.robot[1]: give exactly one of name"},
        BadCase{"unknown robot", kHead + "robot { name: \"nobody\" }\n", "s.textproto:4:9: ScenarioRobot.name: unknown robot 'nobody'"},
        BadCase{"missing robot file", kHead + "robot { file: \"nope.textproto\" }\n", "s.textproto:4:9: ScenarioRobot.file: /some/dir/nope.textproto: cannot read"},
        BadCase{"start not finite", kHead + "robot { name: \"op3\" start { x_m: inf } }\n", "StartPose.x_m"},
        BadCase{"push robot", kHead + "push { time_s: 1 robot: 3 duration_s: 0.1 }\n", "s.textproto:4:18: Push.robot: robot 3 does not exist"},
        BadCase{"push after the end", kHead + "push { time_s: 2 duration_s: 0.1 }\n", "s.textproto:4:8: Push.time_s: at 2.000000 s, not before the end"},
        BadCase{"push negative time", kHead + "push { time_s: -1 duration_s: 0.1 }\n", "Push.time_s: must be a finite time"},
        BadCase{"push no duration", kHead + "push { time_s: 1 fx_n: 5 }\n", "Push.duration_s"},
        BadCase{"push part of a step", kHead + "push { time_s: 1 duration_s: 0.0005 }\n", "Push.duration_s: must be > 0 s in whole milliseconds"},
        BadCase{"push force", kHead + "push { time_s: 1 duration_s: 0.1 fx_n: nan }\n", "Push.fx_n"},
        BadCase{"push spread", kHead + "push { time_s: 1 duration_s: 0.1 time_spread_s: -1 }\n", "Push.time_spread_s"},
        BadCase{"ball velocity", kHead + "ball { time_s: 1 vx_m_s: 1e6 }\n", "s.textproto:4:18: BallMove.vx_m_s: must be finite"},
        BadCase{"ball time", kHead + "ball { time_s: 5 }\n", "BallMove.time_s"},
        BadCase{"empty controller", kHead + "controller { robot: 0 }\n", "s.textproto:4:1: Controller.argv: missing command"},
        BadCase{"controller robot", kHead + "controller { argv: \"x\" robot: 2 }\n", "Controller.robot: robot 2 does not exist"},
        BadCase{"unknown placeholder", kHead + "controller { argv: \"x\" argv: \"{port}\" }\n", "s.textproto:4:24: Controller.argv[1]: {port}: unknown placeholder"},
        BadCase{"unclosed placeholder", kHead + "controller { argv: \"x\" argv: \"{link:0\" }\n", "Controller.argv[1]: '{' without '}'"},
        BadCase{"bus out of range", kHead + "controller { argv: \"x\" argv: \"{link:3}\" }\n", "{link:3}: robot 0 has 1 bus(es)"},
        BadCase{"robot out of range", kHead + "controller { argv: \"x\" argv: \"{link:4:0}\" }\n", "{link:4:0}: robot 4 does not exist"},
        BadCase{"bad link", kHead + "controller { argv: \"x\" argv: \"{link:a}\" }\n", "{link:a}: expected {link:BUS} or {link:ROBOT:BUS}"},
        BadCase{"undeclared param", kHead + "controller { argv: \"x\" argv: \"{param:speed}\" }\n", "{param:speed}: no such parameter"},
        BadCase{"duplicate param", kHead + "param { name: \"a\" } param { name: \"a\" }\n", "s.textproto:4:29: Parameter.name: parameter 'a' is given twice"},
        BadCase{"bad param name", kHead + "param { name: \"a-b\" }\n", "Parameter.name"},
        BadCase{"unknown engine", kHead + "physics: \"mujoco\"\n", "s.textproto:4:1: Scenario.physics: 'mujoco' is no engine"},
        BadCase{"fault kind", kHead + "fault { kind: \"melt\" }\n", "s.textproto:4:9: FaultEvent.kind: must be one of overheat"},
        BadCase{"fault robot", kHead + "fault { kind: \"silent\" robot: 2 bus: 0 }\n", "FaultEvent.robot: robot 2 does not exist"},
        BadCase{"fault time", kHead + "fault { kind: \"silent\" bus: 0 time_s: 3 }\n", "FaultEvent.time_s: at 3.000000 s"},
        BadCase{"fault without bus", kHead + "fault { kind: \"overheat\" id: 3 value: 5 }\n", "FaultEvent.bus: missing field 'bus'"},
        BadCase{"fault value range", kHead + "fault { kind: \"weak\" bus: 0 id: 15 value: 2 }\n", "FaultEvent.value: field 'scale' must be within 0..1"},
        BadCase{"fault rate", kHead + "fault { kind: \"drop\" bus: 0 }\n", "FaultEvent.rate: field 'rate' must be within (0, 1]"},
        BadCase{"fault value it takes none", kHead + "fault { kind: \"silent\" bus: 0 value: 3 }\n", "FaultEvent.value: kind silent takes no value"},
        BadCase{"fault duration", kHead + "fault { kind: \"silent\" bus: 0 duration_s: -1 }\n", "FaultEvent.duration_s"},
        BadCase{"long argument", kHead + "controller { argv: \"" + std::string(2000, 'a') + "\" }\n", "Controller.argv[0]: 2000 characters"}),
    [](const ::testing::TestParamInfo<BadCase>& param) {
      std::string name = param.param.what;
      for (char& c : name) if (c == ' ') c = '_';
      return name;
    });

TEST(ScenarioFile, AnUnreadableFileIsNamed) {
  try {
    load_scenario("/no/such/scenario.textproto", kRobots);
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/no/such/scenario.textproto: cannot read scenario file"), std::string::npos)
        << e.what();
  }
}

TEST(ScenarioPlaceholders, ReplaceLinksSecondsSeedAndParameters) {
  Substitutions values;
  values.links = {{"/l/ttyDXL0", "/l/ttyDXL1"}, {"/l/robot1/ttyDXL0"}};
  values.link_dir = "/l";
  values.seconds = 2.5;
  values.seed = 42;
  values.params = {{"speed", "0.08"}};
  EXPECT_EQ(substitute("--port={link:1}", 0, values, "f:1:1"), "--port=/l/ttyDXL1");
  EXPECT_EQ(substitute("{link:0}", 1, values, "f:1:1"), "/l/robot1/ttyDXL0") << "{link:B} is the controller's robot";
  EXPECT_EQ(substitute("{link:1:0}", 0, values, "f:1:1"), "/l/robot1/ttyDXL0");
  EXPECT_EQ(substitute("{link_dir}/x{seed}", 0, values, "f:1:1"), "/l/x42");
  EXPECT_EQ(std::stod(substitute("{seconds}", 0, values, "f:1:1")), 2.5);
  EXPECT_EQ(substitute("v={param:speed}!", 0, values, "f:1:1"), "v=0.08!");
  EXPECT_EQ(substitute("plain", 0, values, "f:1:1"), "plain");
  EXPECT_THROW(substitute("{link:2}", 0, values, "f:1:1"), std::invalid_argument);
  EXPECT_THROW(substitute("{param:period}", 0, values, "f:1:1"), std::invalid_argument);
}

TEST(ScenarioPlaceholders, ParamsAreNameEqualsValue) {
  EXPECT_EQ(parse_param("speed=0.1"), (std::pair<std::string, std::string>{"speed", "0.1"}));
  EXPECT_EQ(parse_param("s=a=b"), (std::pair<std::string, std::string>{"s", "a=b"}));
  EXPECT_EQ(parse_param("e="), (std::pair<std::string, std::string>{"e", ""}));
  EXPECT_THROW(parse_param("speed"), std::invalid_argument);
  EXPECT_THROW(parse_param("=3"), std::invalid_argument);
  EXPECT_THROW(parse_param("a b=3"), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::scenario
