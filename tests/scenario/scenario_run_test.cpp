// Scenario runs in this process against the real gateway and physics (real time: judged on
// simulation time and on where things ended up, never on the wall clock): the schedule acts at its
// simulation times, the metrics match physics worked out by hand, the controller's life (exit,
// stop, cannot start) is reported, and the command prints one JSON object of the documented shape.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "scenario/run.h"
#include "scenario/scenario.h"

namespace doppel::scenario {
namespace {

using nlohmann::json;
const std::string kRobots = DOPPEL_SOURCE_ROBOTS_DIR;

class ScenarioRun : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("doppel-scenario-test-" + std::to_string(::getpid()) + "-" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }
  json run(const std::string& text, RunOptions options = {}) {
    const Scenario scenario = load_scenario(write("s.textproto", text), kRobots);
    options.tool_dirs = default_tool_dirs();
    return run_scenario(scenario, options);
  }
  std::filesystem::path dir_;
};

// A held robot (no controller switches its servos on) stays where the file put it, and the ball
// moved at 0.1 s rolls on from there: the start pose, the ball move and the distance metrics.
TEST_F(ScenarioRun, ARobotStandsWhereItsStartPoseSaysAndTheBallGoesWhereTheScheduleSays) {
  const json result = run(R"(
    name: "placed" duration_s: 0.5
    robot { name: "fumanoid-2011" start { x_m: 0.5 y_m: -0.3 yaw_deg: 90 } }
    ball { time_s: 0.1 x_m: 2 y_m: 1 vx_m_s: 0.5 })");
  EXPECT_EQ(result["ended"], "duration");
  EXPECT_DOUBLE_EQ(result["sim_time_s"].get<double>(), 0.5);
  const json& m = result["metrics"][0];
  EXPECT_NEAR(m["end"]["x_m"].get<double>(), 0.5, 0.005);
  EXPECT_NEAR(m["end"]["y_m"].get<double>(), -0.3, 0.005);
  EXPECT_NEAR(m["end"]["yaw_deg"].get<double>(), 90.0, 1.0);
  EXPECT_LT(m["distance_m"].get<double>(), 0.005);
  EXPECT_FALSE(m["fallen"].get<bool>());
  EXPECT_LT(m["peak_tilt_deg"].get<double>(), 5.0);
  EXPECT_NEAR(m["energy_j"].get<double>(), 0.0, 0.01) << "no servo has torque: no supply current";
  EXPECT_EQ(result["events"][0]["applied_s"], 0.1);
  // 0.4 s at 0.5 m/s at most 0.2 m; a ball that starts sliding slows to 3/5 (hollow) or 5/7 (solid
  // sphere) of its speed when it rolls, so it gets at least 0.4 x 0.5 x 0.6 = 0.12 m.
  const json& ball = result["ball_end_m"];
  EXPECT_GT(ball[0].get<double>(), 2.12);
  EXPECT_LT(ball[0].get<double>(), 2.201);
  EXPECT_NEAR(ball[1].get<double>(), 1.0, 0.001);
  EXPECT_NEAR(ball[2].get<double>(), 0.0335, 0.002) << "on the carpet (radius 33.5 mm)";
}

const std::string kStiff = std::string(R"(
    robot { name: "fumanoid-2011" start { x_m: 0.5 y_m: -0.3 yaw_deg: 90 } }
    controller { argv: ")") + DOPPEL_STAND_STIFF + R"(" argv: "{link:0}" }
    metrics { distance: true time_to_fall: true peak_tilt: true energy: true })";

// A robot standing stiff (every servo on, holding its initial pose) pushed hard sideways at 1.5 s
// falls over: nothing happens before the push, it tips beyond 45 degrees after it, and lands on its
// side (a lying robot is at 90 degrees) to its right (pushed along +x while facing +y). In lockstep,
// so that the controller has switched the servos on long before the push however slowly Python
// starts on a loaded machine (in real time, a controller that started late would leave the robot held at the push).
TEST_F(ScenarioRun, APushAtItsTimeTipsARobotOver) {
  const json pushed = run("name: \"pushed\" duration_s: 3 lockstep: true\npush { time_s: 1.5 fx_n: 40 duration_s: 0.2 }" + kStiff);
  ASSERT_EQ(pushed["ended"], "duration") << pushed.dump(2);
  EXPECT_EQ(pushed["events"][0]["applied_s"], 1.5);
  const json& m = pushed["metrics"][0];
  ASSERT_TRUE(m["fallen"].get<bool>()) << m.dump(2);
  EXPECT_GT(m["time_to_fall_s"].get<double>(), 1.5) << "it stood until the push";
  EXPECT_LT(m["time_to_fall_s"].get<double>(), 3.0);
  EXPECT_GT(m["peak_tilt_deg"].get<double>(), 45.0);
  EXPECT_LT(m["peak_tilt_deg"].get<double>(), 110.0);
  EXPECT_GT(m["peak_tilt_s"].get<double>(), 1.5);
  EXPECT_LT(m["lateral_m"].get<double>(), -0.05) << "fell to its right, +x";
  EXPECT_EQ(pushed["controllers"][0]["stopped_by_doppel"], true);
  EXPECT_NE(pushed["controllers"][0]["stdout_tail"].get<std::string>().find("torque on"), std::string::npos);

  const json calm = run("name: \"calm\" duration_s: 3 lockstep: true" + kStiff);
  EXPECT_FALSE(calm["metrics"][0]["fallen"].get<bool>()) << calm.dump(2);
  EXPECT_LT(calm["metrics"][0]["peak_tilt_deg"].get<double>(), 20.0);
  EXPECT_LT(calm["metrics"][0]["distance_m"].get<double>(), 0.05);
}

// doppel_run: the controller opens the device name it hard-codes (/dev/ttyUSB0) and reaches the
// robot through doppel-run's shim: its servos draw power once it switched them on (a held robot's
// draw nothing, first test). In lockstep, so that they are on from the controller's first wait
// however slowly it starts.
TEST_F(ScenarioRun, ThroughDoppelRunAControllerReachesTheRobotByItsUsbDeviceName) {
  const json result = run(std::string(R"(name: "shim" duration_s: 1.5 lockstep: true
    robot { name: "fumanoid-2011" }
    metrics { energy: true }
    controller { argv: ")") + DOPPEL_STAND_STIFF + R"(" argv: "/dev/ttyUSB0" doppel_run: true })");
  const json& c = result["controllers"][0];
  EXPECT_NE(c["argv"][0].get<std::string>().find("doppel-run"), std::string::npos);
  EXPECT_NE(c["stdout_tail"].get<std::string>().find("torque on"), std::string::npos) << c.dump(2);
  EXPECT_GT(result["metrics"][0]["energy_drawn_j"].get<double>(), 0.1) << result.dump(2);
}

TEST_F(ScenarioRun, AControllerThatExitsEndsTheRunWithItsStatusAndStderr) {
  const json result = run(R"(name: "quits" duration_s: 600
    robot { name: "fumanoid-2011" }
    controller { argv: "/bin/sh" argv: "-c" argv: "echo starting; echo 'no servo answers' >&2; exit 7" })");
  EXPECT_EQ(result["ended"], "controller_exited");
  EXPECT_LT(result["sim_time_s"].get<double>(), 600.0);
  const json& c = result["controllers"][0];
  EXPECT_EQ(c["exit_code"], 7);
  EXPECT_EQ(c["signal"], nullptr);
  EXPECT_EQ(c["stopped_by_doppel"], false);
  EXPECT_EQ(c["stderr_tail"], "no servo answers\n");
  EXPECT_EQ(c["stdout_tail"], "starting\n");
}

TEST_F(ScenarioRun, AControllerStillRunningAtTheEndIsStopped) {
  const json result = run(R"(name: "sleeper" duration_s: 0.3
    robot { name: "fumanoid-2011" }
    controller { argv: "sleep" argv: "600" })");
  EXPECT_EQ(result["ended"], "duration");
  EXPECT_EQ(result["controllers"][0]["signal"], 15) << "SIGTERM";
  EXPECT_EQ(result["controllers"][0]["stopped_by_doppel"], true);
}

TEST_F(ScenarioRun, AControllerThatCannotStartIsAClearError) {
  const auto error_of = [&](const std::string& program) {
    try {
      run("name: \"x\" duration_s: 1\nrobot { name: \"fumanoid-2011\" }\ncontroller { argv: \"" + program + "\" }");
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(error_of("no-such-controller-xyz").find("s.textproto:3:1: controller program 'no-such-controller-xyz' not found"),
            std::string::npos)
      << error_of("no-such-controller-xyz");
  const std::string garbage = write("garbage", "\x7f" "ELF not really");
  ::chmod(garbage.c_str(), 0700);
  const std::string message = error_of(garbage);
  EXPECT_NE(message.find("cannot start the controller " + garbage + ": Exec format error"), std::string::npos) << message;
  const std::string plain = write("plain.sh", "#!/bin/sh\n");  // not executable
  EXPECT_NE(error_of(plain).find("not found"), std::string::npos);
}

// 2 s of real time: the shell has echoed its line long before, also on a loaded machine.
TEST_F(ScenarioRun, TheCommandPrintsOneJsonObjectOfTheDocumentedShape) {
  const std::string file = write("cli.textproto", R"(name: "cli" duration_s: 2
    robot { name: "fumanoid-2011" }
    param { name: "word" value: "a" }
    controller { argv: "/bin/sh" argv: "-c" argv: "echo {param:word} {seed} {seconds}; sleep 60" })");
  std::ostringstream out, err;
  std::vector<std::string> args = {"scenario", "run", file, "--seed", "5", "--param", "word=b", "--robots-dir", kRobots};
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  ASSERT_EQ(scenario_main(static_cast<int>(argv.size()), argv.data(), out, err), 0) << err.str();
  const std::string text = out.str();
  ASSERT_EQ(std::count(text.begin(), text.end(), '\n'), 1) << "one line: " << text;
  const json result = json::parse(text);
  for (const char* key : {"scenario", "file", "seed", "lockstep", "physics", "duration_s", "sim_time_s", "wall_time_s",
                          "ended", "params", "robots", "controllers", "events", "metrics", "ball_end_m"}) {
    EXPECT_TRUE(result.contains(key)) << key;
  }
  EXPECT_EQ(result["scenario"], "cli");
  EXPECT_EQ(result["seed"], 5);
  EXPECT_EQ(result["params"]["word"], "b");
  EXPECT_EQ(result["controllers"][0]["stdout_tail"], "b 5 2\n");
  const json& m = result["metrics"][0];
  for (const char* key : {"robot", "measured_s", "distance_m", "forward_m", "lateral_m", "end", "fallen", "time_to_fall_s",
                          "energy_j", "energy_drawn_j", "mean_power_w", "peak_tilt_deg", "peak_tilt_s", "control_cycle"}) {
    EXPECT_TRUE(m.contains(key)) << key;
  }
  EXPECT_FALSE(m["control_cycle"]["found"].get<bool>()) << "no driver on the bus: no cycle";
  EXPECT_FALSE(result.contains("hashes")) << "hashes only under lockstep";
}

// The shipped walk under lockstep (issue 15: "two lockstep runs, identical hashes"): the reference
// walk runs through doppel-run --lockstep, the result carries one hash per simulated second, and a
// second run of the same scenario gives the same hashes and the same walk to the last bit.
TEST_F(ScenarioRun, TheShippedWalkUnderLockstepGivesTheSameHashesTwice) {
  const Scenario scenario = load_scenario(DOPPEL_SOURCE_SCENARIOS_DIR "/walk-forward.textproto", kRobots);
  ASSERT_TRUE(scenario.lockstep) << "the shipped walk runs in lockstep";
  RunOptions options;
  options.tool_dirs = default_tool_dirs();
  options.duration_s = 4.0;
  const json first = run_scenario(scenario, options);
  const json second = run_scenario(scenario, options);
  for (const json* result : {&first, &second}) {
    EXPECT_EQ((*result)["ended"], "duration") << result->dump();
    EXPECT_DOUBLE_EQ((*result)["sim_time_s"].get<double>(), 4.0);
    ASSERT_TRUE(result->contains("hashes"));
    ASSERT_EQ((*result)["hashes"].size(), 4u) << (*result)["hashes"].dump();
    for (int s = 0; s < 4; ++s) EXPECT_EQ((*result)["hashes"][s]["second"], s + 1);
    EXPECT_FALSE((*result)["metrics"][0]["fallen"].get<bool>());
  }
  EXPECT_EQ(first["hashes"], second["hashes"]);
  EXPECT_EQ(first["metrics"][0]["end"], second["metrics"][0]["end"]) << "the same walk to the last bit";
  EXPECT_EQ(first["metrics"][0]["energy_j"], second["metrics"][0]["energy_j"]);
}

// A walk through a fault (data/scenarios/walk-weak-knee.textproto): the left knee weakens at 5 s. In
// lockstep every second before the fault hashes as the same walk without it does, the seconds
// after it differ, and the faulted walk is the same to the last bit when run again.
TEST_F(ScenarioRun, AWalkThroughAWeakeningKneeIsTheSameWalkUntilTheFaultAndRepeatsExactly) {
  RunOptions options;
  options.tool_dirs = default_tool_dirs();
  options.duration_s = 8.0;
  const Scenario faulted = load_scenario(DOPPEL_SOURCE_SCENARIOS_DIR "/walk-weak-knee.textproto", kRobots);
  ASSERT_EQ(faulted.faults.size(), 1u);
  EXPECT_EQ(faulted.faults[0].spec.kind, faults::FaultKind::kWeak);
  EXPECT_EQ(faulted.faults[0].spec.id, 15);
  Scenario healthy = faulted;
  healthy.faults.clear();
  const json weak = run_scenario(faulted, options);
  const json again = run_scenario(faulted, options);
  const json plain = run_scenario(healthy, options);
  for (const json* result : {&weak, &again, &plain}) {
    ASSERT_EQ((*result)["ended"], "duration") << result->dump();
    ASSERT_EQ((*result)["hashes"].size(), 8u) << (*result)["hashes"].dump();
  }
  for (int s = 0; s < 4; ++s) EXPECT_EQ(weak["hashes"][s], plain["hashes"][s]) << "second " << s + 1 << ", before the fault";
  for (int s = 5; s < 8; ++s) EXPECT_NE(weak["hashes"][s], plain["hashes"][s]) << "second " << s + 1 << ", after the fault";
  EXPECT_EQ(weak["hashes"], again["hashes"]);
  EXPECT_EQ(weak["metrics"][0]["end"], again["metrics"][0]["end"]);
  ASSERT_EQ(weak["faults"].size(), 1u);
  EXPECT_EQ(weak["faults"][0]["kind"], "weak");
  EXPECT_EQ(weak["faults"][0]["start_s"], 5.0);
  EXPECT_EQ(weak["faults"][0]["end_s"], nullptr);
  std::printf("walk with a weak left knee from 5 s: %s\nwithout: %s\n", weak["metrics"][0].dump().c_str(),
              plain["metrics"][0].dump().c_str());
}

// A fault the gateway cannot place (a servo that is not on the bus) stops the run before it starts.
TEST_F(ScenarioRun, AFaultOnADeviceThatIsNotThereIsAClearError) {
  try {
    run(R"(name: "nofault" duration_s: 1
      robot { name: "fumanoid-2011" }
      fault { kind: "dead" robot: 0 bus: 0 id: 77 time_s: 0.5 })");
    FAIL() << "a fault on ID 77 ran";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("s.textproto:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no device with ID 77"), std::string::npos) << e.what();
  }
}

TEST_F(ScenarioRun, TheCommandRefusesBadInputWithExitCodes) {
  const auto exit_of = [](std::vector<std::string> args, std::string& message) {
    std::ostringstream out, err;
    std::vector<char*> argv;
    for (std::string& arg : args) argv.push_back(arg.data());
    const int code = scenario_main(static_cast<int>(argv.size()), argv.data(), out, err);
    message = err.str();
    EXPECT_EQ(out.str(), "") << "nothing on stdout when it did not run";
    return code;
  };
  std::string message;
  EXPECT_EQ(exit_of({"scenario", "run"}, message), 2);
  EXPECT_EQ(exit_of({"scenario", "walk"}, message), 2);
  EXPECT_EQ(exit_of({"scenario", "run", "/no/such.textproto"}, message), 1);
  EXPECT_NE(message.find("/no/such.textproto: cannot read scenario file"), std::string::npos) << message;
  const std::string file = write("p.textproto", "name: \"p\" duration_s: 1\nrobot { name: \"fumanoid-2011\" }\n");
  EXPECT_EQ(exit_of({"scenario", "run", file, "--param", "speed=1", "--robots-dir", kRobots}, message), 1);
  EXPECT_NE(message.find("--param speed: " + file + " has no such param"), std::string::npos) << message;
  EXPECT_EQ(exit_of({"scenario", "run", file, "--param", "speed", "--robots-dir", kRobots}, message), 1);
  EXPECT_NE(message.find("expected NAME=VALUE"), std::string::npos) << message;
}

}  // namespace
}  // namespace doppel::scenario
