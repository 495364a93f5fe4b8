// A run recorded by doppel itself (--record) replays its fall: the default robot started without
// the start-up handler's hold (--no-hold) and without a driver has no torque and falls over within
// a second or so of simulation time. The replay shows it upright at the start, fallen at the end,
// its trunk lower in the scene, and the fall at one moment in between that a seek finds again.
#include <gtest/gtest.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>

#include "contract/simulation.h"
#include "controlled_doppel.h"
#include "doppel_process.h"
#include "replay/recording.h"
#include "replay/replay_control.h"

namespace doppel::replay {
namespace {

double robot_z_in_scene(contract::Simulation& sut) {
  double highest = -1e9;
  for (const contract::SceneShape& shape : sut.scene().shapes) {
    if (std::string(shape.kind) == "robot") highest = std::max(highest, shape.position[2]);
  }
  return highest;
}

TEST(ReplayRecordedFall, TheRecordedRobotIsUprightAtTheStartAndFallenAtTheEnd) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("doppel-fall-" + std::to_string(getpid()) + ".mcap")).string();
  {
    // 3 s of simulation time, however slowly a loaded machine runs it (60 s of wall time at most).
    testing::ControlledDoppel doppel({"--no-hold", "--record", path});
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (doppel.ok("state")["sim_time_s"].get<double>() < 3.0 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    doppel.doppel.stop();
  }
  const Recording recording(path);
  ASSERT_GT(recording.world().size(), 100u) << "the recording has too few world states to show a fall";
  int64_t wall_ns = 0;
  ReplayControl sut(recording, [&] { return wall_ns; });
  // Judged on the recording's simulation time: the run lasted long enough to fall.
  contract::ReplayChange to_end;
  to_end.position_s = sut.replay().end_s;
  ASSERT_TRUE(sut.change_replay(to_end).ok());
  const contract::SimState end = sut.state();
  ASSERT_GE(end.sim_time_s, 2.9) << "the recording ends at " << end.sim_time_s << " s of simulation time";
  ASSERT_EQ(end.robots.size(), 1u);
  EXPECT_TRUE(end.robots[0].fallen) << "tilt at the end " << end.robots[0].tilt_rad;
  const double z_end = robot_z_in_scene(sut);

  ASSERT_TRUE(sut.reset().ok());
  const contract::SimState start = sut.state();
  EXPECT_FALSE(start.robots[0].fallen) << "tilt at the start " << start.robots[0].tilt_rad;
  EXPECT_LT(start.robots[0].tilt_rad, 0.2);
  const double z_start = robot_z_in_scene(sut);
  EXPECT_GT(z_start, z_end + 0.1) << "the robot's highest shape is at " << z_start << " m at the start, " << z_end << " m at the end";

  // Stepping through it finds the moment of the fall; a seek there shows it again.
  double fell_s = -1.0;
  for (int i = 0; i < 100'000 && !sut.state().robots[0].fallen; ++i) {
    ASSERT_TRUE(sut.step(10).ok());
    fell_s = sut.replay().position_s;
  }
  ASSERT_GT(fell_s, start.sim_time_s);
  contract::ReplayChange back;
  back.position_s = fell_s - 0.05;
  ASSERT_TRUE(sut.change_replay(back).ok());
  EXPECT_FALSE(sut.state().robots[0].fallen);
  back.position_s = fell_s;
  ASSERT_TRUE(sut.change_replay(back).ok());
  EXPECT_TRUE(sut.state().robots[0].fallen);
  std::printf("recorded fall: %.3f s of recording, fallen at %.3f s (sim time %.3f s)\n", sut.replay().end_s, fell_s,
              sut.state().sim_time_s);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace doppel::replay
