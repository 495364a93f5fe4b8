// The DARwIn-OP framework's demo as the robot sees it on its bus (darwin_action_client.cpp: its
// start, the motion file's pages 1 "init", 15 "sit down" and 9 "walkready" as MotionManager sends
// them every 8 ms, then its walk fed from the CM-730's gyro over the bus), against doppel --lockstep
// --robot darwin-op on both engines: no wall clock, so the run is the same on any machine. What it
// guards beyond tests/physics/darwin_walk_test.cpp (the same gait below the bus): the MX-28 control
// table as the framework writes it (angle limits in EEPROM, D/I/P from address 26, Moving Speed 0),
// getting up from the sitting pose at the pages' gains, and the balance fed through the CM-730's
// registers. The real framework's run: scripts/check-darwin-framework --action --lockstep.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <regex>
#include <string>

#include "controlled_doppel.h"

namespace doppel::testing {
namespace {

std::string value(const std::string& output, const std::string& name) {
  const std::regex field("(^|[\\s])" + name + "=([^\\s]*)");
  std::smatch match;
  return std::regex_search(output, match, field) ? match[2].str() : "";
}

class DarwinActionOverTheBus : public ::testing::TestWithParam<std::string> {};

TEST_P(DarwinActionOverTheBus, PlaysTheDemosPagesThenWalks) {
  ControlledDoppel doppel({"--robot", "darwin-op", "--physics", GetParam(), "--lockstep"}, false);
  doppel.doppel.wait_for_output("running until");
  const nlohmann::json before = doppel.ok("state")["robots"][0];
  const auto [code, output] = run_command(std::string(DOPPEL_RUN) + " --lockstep --link-dir " + doppel.doppel.link_dir() +
                                          " -- " + DARWIN_ACTION_CLIENT + " /dev/ttyUSB0 10");
  const nlohmann::json after = doppel.ok("state")["robots"][0];
  ASSERT_EQ(code, 0) << output << doppel.doppel.output();
  EXPECT_EQ(value(output, "failed"), "0") << output;
  // Every joint within 5 deg (57 counts of 11.378 per deg) of the page's goal 0.5 s after it: the
  // bound catches a page that does not play or a pose the body cannot hold (the sit's knees go to
  // 129 deg), not the servos' last degrees under load.
  for (const std::string page : {"1", "15", "9"}) {
    const std::regex line("page=" + page + " worst_counts=(\\d+) worst_id=(\\d+)");
    std::smatch match;
    ASSERT_TRUE(std::regex_search(output, match, line)) << output;
    EXPECT_LT(std::stoi(match[1].str()), 57) << "page " << page << ", ID " << match[2].str();
  }
  EXPECT_FALSE(after["fallen"].get<bool>()) << "tilt " << after["tilt"] << " rad, pose " << after["pose"].dump();
  // Walking's stride (2 x 15 mm per step, 2 steps per 608 ms) for 10 s: 0.99 m; the bounds catch a
  // walk that stalls or runs away (the body oversteps 1.4 times, docs/fidelity.md).
  const double yaw = before["pose"]["yaw"].get<double>();
  const double dx = after["pose"]["x"].get<double>() - before["pose"]["x"].get<double>();
  const double dy = after["pose"]["y"].get<double>() - before["pose"]["y"].get<double>();
  const double forward = std::cos(yaw) * dx + std::sin(yaw) * dy;
  const double commanded = 2 * 0.015 * (2 / 0.608) * 10;
  EXPECT_GT(forward, 0.5 * commanded) << output;
  EXPECT_LT(forward, 2.0 * commanded) << output;
  std::printf("%s: forward %.3f m (commanded %.3f), sideways %.3f m, heading %.3f rad\n%s", GetParam().c_str(), forward,
              commanded, -std::sin(yaw) * dx + std::cos(yaw) * dy,
              std::remainder(after["pose"]["yaw"].get<double>() - yaw, 2 * std::numbers::pi), output.c_str());
}

INSTANTIATE_TEST_SUITE_P(Engines, DarwinActionOverTheBus, ::testing::Values("ode", "bullet"));

}  // namespace
}  // namespace doppel::testing
