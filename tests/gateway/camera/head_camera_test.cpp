// The default robot's head camera streams as soon as doppel runs, and a vision developer gets its
// frames with doppel-camera. Its own executable: it starts RouDi, so it holds the `roudi` lock.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "doppel_process.h"

namespace doppel::testing {
namespace {

TEST(HeadCamera, StreamsFromTheDefaultRobotAndFramesCanBeSaved) {
  DoppelProcess doppel({"--timing", "fast"}, "ttyDXL0", /*camera=*/true);
  // Its first port's link appears once everything is set up and its bus is served; the listing
  // ("running until") comes after.
  const std::string output = doppel.wait_for_output("running until");
  EXPECT_NE(output.find("camera 'HEAD_CAMERA'"), std::string::npos) << output;
  // iceoryx's own lines only with --verbose (issue 16).
  EXPECT_EQ(output.find("Reserving"), std::string::npos) << output;
  EXPECT_EQ(output.find("Log level set to"), std::string::npos) << output;
  auto [list_code, list] = run_command(std::string(DOPPEL_CAMERA_TOOL) + " list");
  ASSERT_EQ(list_code, 0) << list;
  EXPECT_NE(list.find("HEAD_CAMERA"), std::string::npos) << list;

  std::string out = doppel.link_dir() + "/frames";
  auto [save_code, save] = run_command(std::string(DOPPEL_CAMERA_TOOL) + " save --camera HEAD_CAMERA --count 2 --out " + out);
  ASSERT_EQ(save_code, 0) << save;
  int pngs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(out)) {
    pngs += entry.path().extension() == ".png" ? 1 : 0;
  }
  EXPECT_EQ(pngs, 2) << save;
}

TEST(HeadCamera, NoCameraStreamsNothing) {
  DoppelProcess doppel({"--timing", "fast"});  // --no-camera
  std::string output = doppel.wait_for_output("running until");
  ASSERT_NE(output.find("running until"), std::string::npos) << output;
  EXPECT_EQ(output.find("camera '"), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::testing
