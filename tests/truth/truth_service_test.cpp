// The doppel-truth thread with a physics world, without doppel: robots get and lose their sensor
// while it runs (add_robot / remove_robot), each on its own UDP port (base + index); a second topic
// shares the transport through a poller; settings change while it runs and a bad one is refused.
#include <gtest/gtest.h>

#include <chrono>
#include <set>
#include <thread>

#include "rigs.h"
#include "truth/subscriber.h"
#include "truth/truth_service.h"

namespace doppel::truth {
namespace {

// Two free consecutive loopback ports: base for robot 0, base + 1 for robot 1.
struct Ports {
  Ports() {
    for (int attempt = 0; attempt < 50 && robot1 == nullptr; ++attempt) {
      robot0 = std::make_unique<UdpReceiver>(0);
      try {
        robot1 = std::make_unique<UdpReceiver>(static_cast<uint16_t>(robot0->port() + 1));
      } catch (const std::runtime_error&) {
      }
    }
  }
  std::unique_ptr<UdpReceiver> robot0, robot1;
};

// Steps `world` for `ms` milliseconds, capturing after every step as doppel's simulation thread does.
void run(physics::World& world, TruthService& service, int ms) {
  for (int i = 0; i < ms; ++i) {
    world.step();
    service.capture(world, world.time_ns());
    if (i % 20 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // let the thread keep up
  }
}

// Robot indices of the world-model messages that arrive on `port` within `seconds`.
std::set<uint32_t> robots_heard(UdpReceiver& port, double seconds, std::set<std::string>* topics = nullptr) {
  std::set<uint32_t> out;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < deadline) {
    const std::optional<Datagram> d = port.receive(0.1);
    if (!d) continue;
    if (topics != nullptr) topics->insert(d->topic);
    if (d->topic == kWorldModelTopic) out.insert(d->robot);
  }
  return out;
}

TEST(TruthService, RobotsComeAndGoWhileItRunsEachOnItsOwnPort) {
  Ports ports;
  ASSERT_NE(ports.robot1, nullptr) << "no two consecutive free UDP ports on loopback";
  auto world = physics::test::make_world(
      "ode", {physics::test::robot_from_text(physics::test::servo_rig("shape { box { size_m { x: 0.1 y: 0.1 z: 0.1 } } } mass_kg: 1"))});
  TruthOptions options;
  options.transport.iceoryx = false;
  options.transport.udp_base_port = ports.robot0->port();
  TruthService service(options);
  int polls = 0;
  service.add_poller([&polls](Transport& transport) {
    if (++polls % 50 == 0) transport.send(0, "sensor_levels", "levels");
  });
  contract::WorldModelSettings settings;
  settings.rate_hz = 100.0;
  ASSERT_EQ(service.add_robot(0, {0, 0, false, 0, Eigen::Isometry3d::Identity()}, settings), "");
  service.start();
  run(*world, service, 200);
  std::set<std::string> topics;
  EXPECT_EQ(robots_heard(*ports.robot0, 1.0, &topics), std::set<uint32_t>{0});
  EXPECT_EQ(topics, (std::set<std::string>{"world_model", "sensor_levels"})) << "a second topic on the same port";

  // Robot 1 joins (the same body, another index), robot 0 leaves.
  ASSERT_EQ(service.add_robot(1, {0, 1, false, 0, Eigen::Isometry3d::Identity()}, settings), "");
  service.remove_robot(0);
  run(*world, service, 50);  // the changes reach the simulation side
  robots_heard(*ports.robot0, 0.3);  // whatever was on its way
  robots_heard(*ports.robot1, 0.3);
  run(*world, service, 200);
  EXPECT_EQ(robots_heard(*ports.robot1, 1.0), std::set<uint32_t>{1});
  EXPECT_TRUE(robots_heard(*ports.robot0, 0.5).empty()) << "robot 0 was removed";
  EXPECT_FALSE(service.settings(0).has_value());

  // Settings change while running; a bad one is refused naming the field and changes nothing.
  settings.fov_deg = 200.0;
  EXPECT_NE(service.set_settings(1, settings).find("fov_deg"), std::string::npos);
  EXPECT_EQ(service.settings(1)->fov_deg, 0.0);
  EXPECT_NE(service.set_settings(0, settings).find("no world-model sensor"), std::string::npos);
  settings.fov_deg = 0.0;
  settings.enabled = false;
  EXPECT_EQ(service.set_settings(1, settings), "");
  run(*world, service, 50);
  robots_heard(*ports.robot1, 0.3);
  run(*world, service, 200);
  EXPECT_TRUE(robots_heard(*ports.robot1, 0.5).empty()) << "disabled";
  service.stop();
  const TruthStats stats = service.stats();
  EXPECT_GT(stats.messages, 0u);
  EXPECT_EQ(stats.transport.udp_failed, 0u);
}

TEST(TruthService, BadSettingsOrTransportAreRefusedAtSetup) {
  TruthOptions options;
  options.transport.iceoryx = false;
  options.transport.udp_address = "not-an-address";
  EXPECT_THROW(TruthService{options}, std::invalid_argument);
  options.transport.udp_address = "127.0.0.1";
  TruthService service(options);
  contract::WorldModelSettings settings;
  settings.dropout = 1.0;
  EXPECT_NE(service.add_robot(0, {}, settings).find("dropout"), std::string::npos);
  EXPECT_FALSE(service.settings(0).has_value()) << "nothing half-added";
  EXPECT_NE(service.add_robot(kMaxRobots, {}, {}).find("robot"), std::string::npos);
}

}  // namespace
}  // namespace doppel::truth
