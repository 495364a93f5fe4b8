// Issue 14's "done when" for the session handshake, end to end: a handshake adds a second robot to a
// running doppel; its pty answers PING and its camera streams; removing it removes its links. Its own
// executable: doppel runs a camera, so it holds the `roudi` lock.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "doppel_process.h"
#include "reference_client.h"
#include "test_client.h"

namespace doppel::testing {
namespace {

using handshake::testing::TestClient;
namespace wire = doppel::proto::handshake;

std::string link_of(const wire::Robot& robot, const std::string& kind) {
  for (const wire::Link& link : robot.link()) {
    if (link.kind() == kind) {
      return link.location();
    }
  }
  return "";
}

TEST(HandshakeEndToEnd, AddsASecondRobotThatAnswersPingAndStreamsThenRemovesItsLinks) {
  DoppelProcess doppel({"--timing", "fast", "--no-handshake-tcp"}, "ttyDXL0", /*camera=*/true);
  const std::string started = doppel.wait_for_output("running until");
  const std::string socket_path = doppel.link_dir() + "/handshake.sock";
  ASSERT_NE(started.find("unix " + socket_path), std::string::npos) << started;

  TestClient client = TestClient::unix_socket(socket_path);
  wire::ClientMessage add;
  add.mutable_add_robot()->set_robot("fumanoid-2011");
  wire::CameraRequest* camera = add.mutable_add_robot()->add_camera();
  camera->set_name("HEAD_CAMERA");
  camera->set_width_px(320);
  camera->set_height_px(240);
  const wire::ServerMessage added = client.call(add);
  ASSERT_TRUE(added.has_robot_added()) << added.ShortDebugString();
  const wire::Robot& robot = added.robot_added();
  EXPECT_EQ(robot.robot(), 1u);
  const std::string bus = link_of(robot, "bus");
  const std::string stream = link_of(robot, "camera");
  std::string camera_name;
  for (const wire::Link& link : robot.link()) {
    camera_name = link.kind() == "camera" ? link.name() : camera_name;
  }
  ASSERT_FALSE(bus.empty()) << robot.ShortDebugString();
  ASSERT_FALSE(stream.empty()) << robot.ShortDebugString();
  ASSERT_TRUE(std::filesystem::exists(bus)) << bus;

  {
    // fumanoid-2011: servo ID 1 at 1 Mbps (data/robots/fumanoid-2011.textproto). Golden reply: a status
    // packet of ID 1 with no error and no parameters (reference §1.1).
    SerialClient port(bus, 1000000);
    const Bytes reply = port.transact(p1_instruction(1, 0x01), 6, 1000);
    const auto statuses = parse_p1_statuses(reply);
    ASSERT_TRUE(statuses && statuses->size() == 1) << reply.size();
    EXPECT_EQ(statuses->at(0).id, 1);
    EXPECT_EQ(statuses->at(0).error, 0);
  }

  const std::string out = doppel.link_dir() + "/frames";
  auto [save_code, save] = run_command(std::string(DOPPEL_CAMERA_TOOL) + " save --camera " + camera_name +
                                       " --count 1 --out " + out);
  ASSERT_EQ(save_code, 0) << save;
  int pngs = 0;
  for (const auto& entry : std::filesystem::directory_iterator(out)) {
    pngs += entry.path().extension() == ".png" ? 1 : 0;
  }
  EXPECT_EQ(pngs, 1) << save;

  wire::ClientMessage remove;
  remove.mutable_remove_robot()->set_robot(robot.robot());
  const wire::ServerMessage removed = client.call(remove);
  ASSERT_TRUE(removed.has_removed()) << removed.ShortDebugString();
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::symlink_status(bus))) << bus;
  wire::ClientMessage list;
  list.mutable_list_robots();
  EXPECT_EQ(client.call(list).robot_list().robot_size(), 1);
  auto [list_code, cameras] = run_command(std::string(DOPPEL_CAMERA_TOOL) + " list");
  EXPECT_EQ(cameras.find(camera_name + " "), std::string::npos) << cameras;
  EXPECT_TRUE(std::filesystem::exists(doppel.link("ttyDXL0")));  // the first robot stays
}

}  // namespace
}  // namespace doppel::testing
