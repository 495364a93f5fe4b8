// Robots added to and removed from a running doppel through contract::RobotHost (the contract the
// session handshake serves; docs/robots-at-run-time.md), in process: the new robot's bus answers
// a Protocol 1.0 PING from the reference client and its simulation runs; removing it removes its
// links; bad requests are refused naming the field and leave nothing behind; the robot doppel
// started with keeps answering throughout. Cameras: camera/live_robots_camera.cpp.

#include <gtest/gtest.h>
#include <stdlib.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <set>
#include <thread>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "contract/robot_host.h"
#include "gateway/gateway.h"
#include "proto/truth.pb.h"
#include "reference_client.h"
#include "truth/subscriber.h"
#include "sim_time.h"

#include <httplib.h>  // after Eigen (gateway.h): a macro of it breaks Eigen's headers

namespace doppel::testing {
namespace {

namespace fs = std::filesystem;
using contract::Refusal;
using contract::RobotAdded;
using contract::RobotRequest;

constexpr uint8_t kPing = 0x01;

// PINGs servo 1 (HEAD_PITCH of fumanoid-2011) and checks its status: ID 1, no error, no parameters.
void expect_ping_answered(SerialClient& client, const std::string& what) {
  const Bytes reply = client.transact(p1_instruction(1, kPing), 6, 1000);
  const auto statuses = parse_p1_statuses(reply);
  ASSERT_TRUE(statuses.has_value()) << what << ": malformed reply of " << reply.size() << " bytes";
  ASSERT_EQ(statuses->size(), 1u) << what;
  EXPECT_EQ((*statuses)[0].id, 1) << what;
  EXPECT_EQ((*statuses)[0].error, 0) << what;
  EXPECT_TRUE((*statuses)[0].params.empty()) << what;
}

class LiveRobots : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/doppel-live-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
    options_.buses.link_dir = dir_ + "/links";
    options_.buses.robots = {"fumanoid-2011"};
    options_.buses.robots_dir = DOPPEL_ROBOTS_DIR;
    options_.buses.timing = bus::TimingMode::kFast;
    options_.cameras.enabled = false;
    options_.viewer.enabled = true;  // simulation control on any free port: the new robot shows in /api/state
    options_.viewer.port = 0;
    options_.state.dir.clear();
    gateway_ = std::make_unique<gateway::Gateway>(options_);
    gateway_->start();
    first_ = std::make_unique<SerialClient>(options_.buses.link_dir + "/ttyDXL0", 1000000);
  }
  void TearDown() override {
    first_.reset();
    gateway_.reset();
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  contract::RobotHost& host() { return gateway_->robot_host(); }

  nlohmann::json get(const std::string& path) {
    httplib::Client client("127.0.0.1", gateway_->control_port());
    client.set_read_timeout(std::chrono::seconds(10));
    client.set_bearer_token_auth(gateway_->access_token());
    const httplib::Result result = client.Get(path);
    if (!result || result->status != 200) {
      ADD_FAILURE() << "GET " << path << " failed";
      return nlohmann::json::object();
    }
    return nlohmann::json::parse(result->body);
  }
  nlohmann::json state() { return get("/api/state"); }

  // The robots the viewer's scene draws (distinct object ids of robot shapes), once the scene was
  // taken after `after_s` of simulation time.
  std::set<int> robots_in_scene(double after_s) {
    for (int i = 0; i < 500; ++i) {
      const nlohmann::json scene = get("/api/scene");
      if (scene.value("sim_time_s", 0.0) > after_s) {
        std::set<int> objects;
        for (const auto& shape : scene["shapes"]) {
          if (shape["kind"] == "robot") objects.insert(shape["object"].get<int>());
        }
        return objects;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "the scene did not pass " << after_s << " s";
    return {};
  }

  // Refused, naming `field`; nothing of it is left: one robot, no robot1 link.
  void expect_refused(const RobotRequest& request, const std::string& field) {
    const contract::AddResult result = host().add_robot(request);
    ASSERT_TRUE(std::holds_alternative<Refusal>(result)) << field;
    const Refusal& refusal = std::get<Refusal>(result);
    EXPECT_EQ(refusal.field, field) << refusal.message;
    EXPECT_FALSE(refusal.message.empty()) << field;
    EXPECT_EQ(host().robots().size(), 1u) << field;
    EXPECT_FALSE(fs::exists(fs::symlink_status(options_.buses.link_dir + "/robot1/ttyDXL0"))) << field;
  }

  std::string dir_;
  gateway::Options options_;
  std::unique_ptr<gateway::Gateway> gateway_;
  std::unique_ptr<SerialClient> first_;
};

RobotRequest named(const std::string& robot) {
  RobotRequest request;
  request.robot = robot;
  return request;
}

const contract::Link* find_link(const RobotAdded& added, const std::string& kind, const std::string& name) {
  for (const contract::Link& link : added.links) {
    if (link.kind == kind && link.name == name) return &link;
  }
  return nullptr;
}

TEST_F(LiveRobots, ASecondRobotIsServedWhileDoppelRunsAndRemovingItRemovesItsLinks) {
  expect_ping_answered(*first_, "the first robot before");
  // The first robot's bus answers every PING while the second is added, served and removed.
  std::atomic<bool> done{false};
  std::atomic<int> answered{0}, unanswered{0};
  std::thread pinger([&] {
    while (!done.load()) {
      const auto statuses = parse_p1_statuses(first_->transact(p1_instruction(1, kPing), 6, 1000));
      (statuses && statuses->size() == 1 && (*statuses)[0].id == 1 ? answered : unanswered).fetch_add(1);
    }
  });
  RobotRequest request = named("fumanoid-2011");
  request.x_m = 1.0;
  request.y_m = 1.5;
  request.team = 1;
  const contract::AddResult result = host().add_robot(request);
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(result)) << std::get<Refusal>(result).field << ": "
                                                          << std::get<Refusal>(result).message;
  const RobotAdded& added = std::get<RobotAdded>(result);
  EXPECT_EQ(added.robot, 1u);
  EXPECT_EQ(added.name, "fumanoid-2011");
  const contract::Link* bus = find_link(added, "bus", "ttyDXL0");
  const contract::Link* timer = find_link(added, "latency_timer", "ttyDXL0");
  ASSERT_NE(bus, nullptr);
  ASSERT_NE(timer, nullptr);
  EXPECT_EQ(bus->location, options_.buses.link_dir + "/robot1/ttyDXL0");
  EXPECT_EQ(timer->location, options_.buses.link_dir + "/robot1/ttyDXL0.latency_timer");
  std::ifstream timer_file(timer->location);
  int latency_ms = 0;
  EXPECT_TRUE(timer_file >> latency_ms) << "the latency-timer file holds the adapter's value";
  ASSERT_EQ(host().robots().size(), 2u);
  EXPECT_EQ(host().robots()[1].links.size(), added.links.size());

  {
    SerialClient second(bus->location, 1000000);
    expect_ping_answered(second, "the added robot");
    wait_sim_time(second, 0.2);  // its IMU counts simulation time: it is simulated
  }
  // Simulation control (the viewer, doppel-ctl) shows it where it was put, held by the handler.
  const nlohmann::json shown = state();
  ASSERT_EQ(shown["robots"].size(), 2u) << shown.dump();
  EXPECT_EQ(shown["robots"][1]["name"], "fumanoid-2011");
  EXPECT_TRUE(shown["robots"][1]["simulated"].get<bool>());
  EXPECT_TRUE(shown["robots"][1]["held"].get<bool>());
  EXPECT_NEAR(shown["robots"][1]["pose"]["x"].get<double>(), 1.0, 0.01);
  EXPECT_NEAR(shown["robots"][1]["pose"]["y"].get<double>(), 1.5, 0.01);
  EXPECT_FALSE(shown["robots"][1]["imus"].empty());

  EXPECT_FALSE(host().remove_robot(1).has_value());
  EXPECT_FALSE(fs::exists(fs::symlink_status(bus->location))) << "its link is gone";
  EXPECT_FALSE(fs::exists(fs::symlink_status(timer->location))) << "its latency-timer file is gone";
  EXPECT_EQ(host().robots().size(), 1u);
  EXPECT_EQ(state()["robots"].size(), 1u);
  done = true;
  pinger.join();
  EXPECT_GT(answered.load(), 10);
  EXPECT_EQ(unanswered.load(), 0) << "the first robot's bus missed PINGs";
  expect_ping_answered(*first_, "the first robot after the removal");
  wait_sim_time(*first_, 0.2);

  // Removing what is not there, or what doppel started with, is refused.
  const std::optional<Refusal> again = host().remove_robot(1);
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->field, "robot");
  const std::optional<Refusal> started = host().remove_robot(0);
  ASSERT_TRUE(started.has_value());
  EXPECT_EQ(started->field, "robot");
  expect_ping_answered(*first_, "the first robot after the refusals");

  // The slot is free again.
  const contract::AddResult back = host().add_robot(named("fumanoid-2011"));
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(back));
  EXPECT_EQ(std::get<RobotAdded>(back).robot, 1u);
  SerialClient second(options_.buses.link_dir + "/robot1/ttyDXL0", 1000000);
  expect_ping_answered(second, "the robot added again");
}

// The threads of this process named `name` now (/proc/self/task/*/comm).
int threads_named(const std::string& name) {
  int n = 0;
  for (const auto& task : fs::directory_iterator("/proc/self/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string each;
    std::getline(comm, each);
    n += each == name ? 1 : 0;
  }
  return n;
}

// An added robot's link appears only once its bus thread runs, as the links of the robots doppel
// started with: a script watching the link directory may write the moment it sees it.
TEST_F(LiveRobots, AnAddedRobotsLinkAppearsOnlyOnceItsBusIsServed) {
  ASSERT_EQ(threads_named("doppel-bus"), 1);
  const std::string link = options_.buses.link_dir + "/robot1/ttyDXL0";
  std::atomic<int> bus_threads_when_seen{-1};
  std::atomic<bool> stop{false};
  std::thread watcher([&] {
    while (!stop.load()) {
      if (fs::exists(fs::symlink_status(link))) {
        bus_threads_when_seen = threads_named("doppel-bus");
        return;
      }
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  });
  const contract::AddResult result = host().add_robot(named("fumanoid-2011"));
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(result)) << std::get<Refusal>(result).message;
  for (int i = 0; i < 100'000 && bus_threads_when_seen.load() < 0; ++i) {
    std::this_thread::sleep_for(std::chrono::microseconds(100));
  }
  stop = true;
  watcher.join();
  EXPECT_EQ(bus_threads_when_seen.load(), 2) << "the added robot's bus thread ran when its link appeared";
  SerialClient second(link, 1000000);
  expect_ping_answered(second, "the added robot");
}

TEST_F(LiveRobots, ARobotFromAnInlineDescriptionIsServed) {
  std::ifstream file(std::string(DOPPEL_ROBOTS_DIR) + "/fumanoid-2011.textproto");
  RobotRequest request;
  request.description.assign(std::istreambuf_iterator<char>(file), std::istreambuf_iterator<char>());
  const contract::AddResult result = host().add_robot(request);
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(result)) << std::get<Refusal>(result).message;
  SerialClient second(find_link(std::get<RobotAdded>(result), "bus", "ttyDXL0")->location, 1000000);
  expect_ping_answered(second, "the robot from its description");
}

// A failure halfway (here: its port link's place is taken by a regular file, found once the world
// holds its body) undoes what was built: no body stays in the world, nothing is served.
TEST_F(LiveRobots, ARobotThatFailsHalfwayLeavesNothingInTheWorld) {
  fs::create_directories(options_.buses.link_dir + "/robot1");
  std::ofstream(options_.buses.link_dir + "/robot1/ttyDXL0") << "not a link\n";
  const contract::AddResult failed = host().add_robot(named("fumanoid-2011"));
  ASSERT_TRUE(std::holds_alternative<Refusal>(failed));
  EXPECT_EQ(std::get<Refusal>(failed).field, "robot");
  EXPECT_NE(std::get<Refusal>(failed).message.find("robot1/ttyDXL0"), std::string::npos) << std::get<Refusal>(failed).message;
  EXPECT_EQ(host().robots().size(), 1u);
  EXPECT_EQ(state()["robots"].size(), 1u);
  const double now_s = state()["sim_time_s"].get<double>();
  EXPECT_EQ(robots_in_scene(now_s).size(), 1u) << "the failed robot's body was left in the world";

  fs::remove(options_.buses.link_dir + "/robot1/ttyDXL0");
  const contract::AddResult added = host().add_robot(named("fumanoid-2011"));
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(added)) << std::get<Refusal>(added).message;
  EXPECT_EQ(robots_in_scene(state()["sim_time_s"].get<double>()).size(), 2u);
  expect_ping_answered(*first_, "the first robot");
}

TEST_F(LiveRobots, BadRequestsAreRefusedNamingTheFieldAndLeaveNothingBehind) {
  expect_refused(named("no-such-robot"), "robot");
  expect_refused(RobotRequest{}, "robot");
  RobotRequest both = named("fumanoid-2011");
  both.description = "name: \"x\"";
  expect_refused(both, "description");
  RobotRequest garbage;
  garbage.description = "name: \"x\" bus { this is not a robot file";
  expect_refused(garbage, "description");
  RobotRequest half = named("fumanoid-2011");
  half.x_m = 1.0;
  expect_refused(half, "y_m");
  RobotRequest off_carpet = named("fumanoid-2011");
  off_carpet.x_m = 25.0;
  off_carpet.y_m = 0.0;
  expect_refused(off_carpet, "x_m");
  RobotRequest team = named("fumanoid-2011");
  team.team = 2;
  expect_refused(team, "team");
  RobotRequest camera = named("fumanoid-2011");
  camera.cameras.emplace_back().name = "HEAD_CAMERA";
  expect_refused(camera, "cameras");  // this doppel runs with --no-camera
  RobotRequest world_model = named("fumanoid-2011");
  world_model.world_model = contract::WorldModelSettings{};
  expect_refused(world_model, "world_model");  // this doppel runs without --world-model: no truth transport
  RobotRequest levels = named("fumanoid-2011");
  levels.sensor_levels = true;
  expect_refused(levels, "sensor_levels");
  expect_ping_answered(*first_, "the first robot after the refusals");
}

// doppel --world-model (UDP only): a robot added with a world model gets one; its link names the
// UDP port, its messages arrive there under its own index with its own pose where the request put
// it, and they stop when it is removed. A bad setting is refused naming world_model, nothing built.
TEST(LiveRobotsWorldModel, AnAddedRobotsWorldModelArrivesWhereItsLinkSaysAndStopsWithIt) {
  char pattern[] = "/tmp/doppel-live-wm-XXXXXX";
  ASSERT_NE(::mkdtemp(pattern), nullptr);
  const std::string dir = pattern;
  truth::UdpReceiver robot0(0);
  std::unique_ptr<truth::UdpReceiver> robot1;
  try {
    robot1 = std::make_unique<truth::UdpReceiver>(static_cast<uint16_t>(robot0.port() + 1));
  } catch (const std::exception& e) {
    GTEST_SKIP() << "the UDP port after " << robot0.port() << " is taken: " << e.what();
  }
  gateway::Options options;
  options.buses.link_dir = dir + "/links";
  options.buses.robots = {"fumanoid-2011"};
  options.buses.robots_dir = DOPPEL_ROBOTS_DIR;
  options.buses.timing = bus::TimingMode::kFast;
  options.cameras.enabled = false;
  options.viewer.enabled = false;
  options.state.dir.clear();
  options.truth.world_model = true;
  options.truth.iceoryx = false;
  options.truth.udp_port = robot0.port();
  auto gateway = std::make_unique<gateway::Gateway>(options);
  gateway->start();

  RobotRequest bad = named("fumanoid-2011");
  bad.world_model = contract::WorldModelSettings{};
  bad.world_model->fov_deg = 200.0;
  const contract::AddResult refused = gateway->robot_host().add_robot(bad);
  ASSERT_TRUE(std::holds_alternative<Refusal>(refused));
  EXPECT_EQ(std::get<Refusal>(refused).field, "world_model");
  EXPECT_NE(std::get<Refusal>(refused).message.find("fov_deg"), std::string::npos) << std::get<Refusal>(refused).message;
  EXPECT_EQ(gateway->robot_host().robots().size(), 1u);

  RobotRequest request = named("fumanoid-2011");
  request.x_m = 1.5;
  request.y_m = -1.0;
  request.yaw_rad = 0.5;
  request.world_model = contract::WorldModelSettings{};
  request.world_model->rate_hz = 50.0;
  const contract::AddResult result = gateway->robot_host().add_robot(request);
  ASSERT_TRUE(std::holds_alternative<RobotAdded>(result)) << std::get<Refusal>(result).message;
  const RobotAdded& added = std::get<RobotAdded>(result);
  ASSERT_EQ(added.robot, 1u);
  const contract::Link* link = find_link(added, "world_model", "world_model");
  ASSERT_NE(link, nullptr);
  EXPECT_EQ(link->location, "udp:127.0.0.1:" + std::to_string(robot1->port()));

  std::optional<proto::truth::WorldModel> heard;
  for (int i = 0; i < 300 && !heard; ++i) {
    const std::optional<truth::Datagram> d = robot1->receive(0.2);
    if (!d || d->topic != "world_model") continue;
    EXPECT_EQ(d->robot, 1u);
    proto::truth::WorldModel m;
    ASSERT_TRUE(m.ParseFromString(d->payload));
    if (m.world_time_ns() > 200'000'000) heard = m;  // settled onto the carpet
  }
  ASSERT_TRUE(heard.has_value()) << "no world-model message of the added robot on port " << robot1->port();
  EXPECT_EQ(heard->robot(), 1u);
  EXPECT_NEAR(heard->pose().x_m(), 1.5, 0.01);  // held by the handler where it was placed
  EXPECT_NEAR(heard->pose().y_m(), -1.0, 0.01);
  EXPECT_NEAR(heard->pose().yaw_rad(), 0.5, 0.01);
  bool sees_robot0 = false;
  for (const auto& other : heard->robots()) sees_robot0 = sees_robot0 || other.index() == 0;
  EXPECT_TRUE(sees_robot0) << "the robot doppel started with is among the others";

  ASSERT_FALSE(gateway->robot_host().remove_robot(1).has_value());
  while (robot1->receive(0.3)) {
  }  // what was on its way
  EXPECT_FALSE(robot1->receive(1.0).has_value()) << "no messages after the robot was removed";
  gateway.reset();
  std::error_code ignored;
  fs::remove_all(dir, ignored);
}

TEST_F(LiveRobots, ASeventhRobotIsRefused) {
  for (uint32_t r = 1; r < 6; ++r) {
    RobotRequest request = named("fumanoid-2011");
    request.cameras_off = true;
    const contract::AddResult result = host().add_robot(request);
    ASSERT_TRUE(std::holds_alternative<RobotAdded>(result)) << r << ": " << std::get<Refusal>(result).message;
    EXPECT_EQ(std::get<RobotAdded>(result).robot, r);
  }
  const contract::AddResult seventh = host().add_robot(named("fumanoid-2011"));
  ASSERT_TRUE(std::holds_alternative<Refusal>(seventh));
  EXPECT_EQ(std::get<Refusal>(seventh).field, "robot");
  EXPECT_EQ(host().robots().size(), 6u);
  EXPECT_FALSE(fs::exists(fs::symlink_status(options_.buses.link_dir + "/robot6")));
  SerialClient fifth(options_.buses.link_dir + "/robot5/ttyDXL0", 1000000);
  expect_ping_answered(fifth, "the sixth robot");
  expect_ping_answered(*first_, "the first robot among six");
  for (uint32_t r = 1; r < 6; ++r) EXPECT_FALSE(host().remove_robot(r).has_value()) << r;
  EXPECT_EQ(host().robots().size(), 1u);
}

}  // namespace
}  // namespace doppel::testing
