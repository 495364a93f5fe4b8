// Sensor levels in the gateway (docs/multilevel.md, "Sensor levels"): the DARwIn-OP standing in the
// physics world, its bus sampled at the configured rate of simulation time; every servo's, the
// CM-730's and the FSR boards' registers decoded beside the simulation's truth, and a driver that
// reads Present Position over the pty sees what the message says. In-process: the test steps the
// world itself, so it judges simulation time only.
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <thread>

#include "body/kinematic_body.h"
#include "body/physics_body.h"
#include "darwin_op_framework.h"
#include "dynamixel/models.h"
#include "dynamixel/protocol2_models.h"
#include "gateway/gateway.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "physics/engines.h"
#include "physics/world.h"
#include "doppel_process.h"
#include "reference_client.h"
#include "robot_runtime.h"
#include "sensor_levels_feed.h"
#include "truth/subscriber.h"
#include "truth/transport.h"

namespace doppel::gateway {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kG = 9.80665;
constexpr double kCount = 2 * kPi / 4096;  // e-Manual MX-28: 0.088 deg per Present Position unit

// The DARwIn-OP as the framework leaves it after Connect() and MotionManager's first cycle
// (darwin_op_framework.h): the CM-730's Dynamixel Power (24) on, every MX-28 at the walk-ready goal
// with Walking's P gain, torque on.
RobotConfig powered_darwin_op() {
  using namespace testing::darwin;
  RobotConfig config = load_robot("darwin-op", DOPPEL_ROBOTS_DIR);
  for (DeviceConfig& device : config.buses.at(0).devices) {
    if (device.model == "CM-730") device.initial.push_back({24, 1, false, "Dynamixel Power", "test"});
    if (device.model != "MX-28") continue;
    device.initial.push_back({kPGain, p_gain(device.id), false, "P Gain", "test"});
    device.initial.push_back({kDGain, 0, false, "D Gain", "test"});
    device.initial.push_back({kGoalPosition, kWalkReady.at(device.id), false, "Goal Position", "test"});
    device.initial.push_back({kTorqueEnable, 1, false, "Torque Enable", "test"});
  }
  return config;
}

class Rig {
 public:
  explicit Rig(double levels_hz)
      : config_(powered_darwin_op()),
        dir_(std::filesystem::temp_directory_path() / ("doppel-levels-" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(dir_);
    physics::WorldOptions world_options;
    world_options.step_s = 0.001;
    world_ = std::make_unique<physics::World>(physics::make_backend(physics::Engine::kOde),
                                              std::vector<physics::RobotModel>{*config_.body},
                                              std::vector<physics::RobotPlacement>{physics::RobotPlacement{}}, world_options);
    Options options;
    options.buses.link_dir = dir_.string();
    options.buses.timing = bus::TimingMode::kFast;
    options.truth.sensor_levels_hz = levels_hz;
    robot_ = std::make_unique<RobotRuntime>(config_, 0, std::make_unique<body::PhysicsBody>(*world_, 0), options);
  }
  ~Rig() {
    stop_ = true;
    robot_->join();
    robot_.reset();
    std::filesystem::remove_all(dir_);
  }

  // One simulation step as the simulation thread runs it; `tick`: also the bus' tick (only while
  // its thread does not run).
  void step(bool tick) {
    robot_->drive(0.001);
    world_->step();
    robot_->sense(world_->time_ns());
    if (tick) robot_->bus(0).on_tick();
  }
  void start_bus() { robot_->start(stop_, 0); }

  RobotRuntime& robot() { return *robot_; }
  physics::World& world() { return *world_; }
  const RobotConfig& config() const { return config_; }
  std::string link() const { return (dir_ / "ttyDXL0").string(); }

 private:
  RobotConfig config_;
  std::filesystem::path dir_;
  std::unique_ptr<physics::World> world_;
  std::unique_ptr<RobotRuntime> robot_;
  std::atomic<bool> stop_{false};
};

TEST(SensorLevelsGateway, SamplesAtTheConfiguredRateOfSimulationTime) {
  Rig rig(100.0);
  levels::SensorLevels message;
  ASSERT_TRUE(rig.robot().sensor_levels(message)) << "the power-on sample";
  const uint64_t first = message.sequence();
  uint64_t messages = 0;
  for (int i = 0; i < 1000; ++i) {
    rig.step(true);
    if (rig.robot().sensor_levels(message)) {
      ++messages;
      EXPECT_EQ(message.sim_time_ns() % 10'000'000, 0) << "on the 10 ms grid";
    }
  }
  EXPECT_EQ(messages, 100u) << "1 s of simulation at 100 Hz";
  EXPECT_EQ(message.sequence(), first + 100);
  EXPECT_EQ(message.sim_time_ns(), 1'000'000'000);
  EXPECT_EQ(message.robot_name(), rig.config().name);
  EXPECT_EQ(message.servos_size(), 20);
  EXPECT_EQ(message.imus_size(), 1);
  EXPECT_EQ(message.feet_size(), 2);
}

TEST(SensorLevelsGateway, OffUnlessAsked) {
  Rig rig(0.0);
  levels::SensorLevels message;
  rig.step(true);
  EXPECT_FALSE(rig.robot().sensor_levels(message));
}

// Every sample agrees within a register unit: decoded servo registers with the joints (the load with
// the DC-motor model's torque), the CM-730 with the trunk's rates and specific force, the FSR cells
// with the contact forces.
void expect_decoded_is_truth(const levels::SensorLevels& message, const RobotConfig& config) {
  // MX-28 (e-Manual): stall torque at the rated voltage, times supply / rated voltage, is what Present
  // Load 1023 means (the DC motor's stall torque grows with its voltage).
  const dynamixel::MotorSpec& motor = *dynamixel::model_spec("MX-28").servo.motor;
  const double supply_v = config.buses[0].supply_voltage_v;
  const double full_nm = motor.stall_torque_nm * supply_v / motor.rated_voltage_v;
  ASSERT_EQ(message.servos_size(), 20);
  for (const levels::ServoLevels& s : message.servos()) {
    SCOPED_TRACE(s.name());
    EXPECT_TRUE(s.powered());
    EXPECT_EQ(s.model(), "MX-28");
    EXPECT_NEAR(s.decoded().present_position_rad(), s.truth().angle_rad(), kCount);
    EXPECT_NEAR(s.decoded().present_speed_rad_s(), s.truth().velocity_rad_s(), 0.114 * 2 * kPi / 60);
    EXPECT_NEAR(s.decoded().present_load_ratio(), s.truth().load_ratio(), 1.0 / 1023);
    EXPECT_NEAR(s.decoded().present_load_ratio() * full_nm, s.truth().torque_nm(), full_nm / 1023);
    EXPECT_DOUBLE_EQ(s.decoded().present_voltage_v(), supply_v);
    EXPECT_NEAR(s.decoded().present_temperature_c(), s.truth().temperature_c(), 0.5);
  }
  ASSERT_EQ(message.imus_size(), 1);
  const levels::ImuLevels& imu = message.imus(0);
  EXPECT_EQ(imu.model(), "CM-730");
  const double accel_count = 4.0 / 512 * kG, gyro_count = 1600.0 / 512 * kPi / 180;  // CM-730: e-Manual accelerometer, Webots gyro
  const levels::Vector3& a = imu.truth().specific_force_m_s2();
  EXPECT_NEAR(imu.decoded().accel_m_s2().x(), a.x(), accel_count);
  EXPECT_NEAR(imu.decoded().accel_m_s2().y(), a.y(), accel_count);
  EXPECT_NEAR(imu.decoded().accel_m_s2().z(), a.z(), accel_count);
  const levels::Vector3& w = imu.truth().angular_velocity_rad_s();
  EXPECT_NEAR(imu.decoded().gyro_rad_s().x(), w.x(), gyro_count);
  EXPECT_NEAR(imu.decoded().gyro_rad_s().y(), w.y(), gyro_count);
  EXPECT_NEAR(imu.decoded().gyro_rad_s().z(), w.z(), gyro_count);
  ASSERT_EQ(message.feet_size(), 2);
  for (const levels::FootLevels& foot : message.feet()) {
    ASSERT_EQ(foot.decoded_force_n_size(), 4);
    for (int c = 0; c < 4; ++c) {
      const double truth = foot.true_force_n(c), decoded = foot.decoded_force_n(c);
      // e-Manual FSR: 1 mN per unit; below 0.493 N the cell reads 0.
      if (truth >= 0.493) {
        EXPECT_NEAR(decoded, truth, 0.001) << foot.name() << " FSR" << c + 1;
      } else {
        EXPECT_EQ(decoded, 0.0) << foot.name() << " FSR" << c + 1;
      }
    }
  }
}

double norm(const levels::Vector3& v) { return std::sqrt(v.x() * v.x() + v.y() * v.y() + v.z() * v.z()); }

// After 3 s the robot stands on the carpet; over the next second (100 samples) every sample decodes
// to its truth, and on average the accelerometer reads 1 g and the eight cells carry the weight
// (ODE's contacts make a single sample jitter by a few %).
TEST(SensorLevelsGateway, AStandingDarwinOpDecodesToItsTruth) {
  Rig rig(100.0);
  levels::SensorLevels message;
  for (int i = 0; i < 3000; ++i) rig.step(true);
  ASSERT_TRUE(rig.robot().sensor_levels(message));  // the sample at 3 s
  double specific_force = 0.0, true_feet = 0.0, decoded_feet = 0.0, largest_load = 0.0;
  int samples = 0;
  for (int i = 0; i < 1000; ++i) {
    rig.step(true);
    if (!rig.robot().sensor_levels(message)) continue;
    ++samples;
    expect_decoded_is_truth(message, rig.config());
    if (::testing::Test::HasFailure()) break;
    specific_force += norm(message.imus(0).truth().specific_force_m_s2());
    for (const levels::FootLevels& foot : message.feet()) {
      for (int c = 0; c < 4; ++c) {
        true_feet += foot.true_force_n(c);
        decoded_feet += foot.decoded_force_n(c);
      }
    }
    for (const levels::ServoLevels& s : message.servos()) largest_load = std::max(largest_load, std::fabs(s.truth().load_ratio()));
  }
  ASSERT_EQ(samples, 100);
  EXPECT_NEAR(specific_force / samples, kG, 0.01 * kG) << "at rest: gravity only";
  const double weight_n = rig.config().body->mass_kg * kG;
  EXPECT_NEAR(true_feet / samples, weight_n, 0.05 * weight_n);
  EXPECT_NEAR(decoded_feet / samples, weight_n, 0.05 * weight_n);
  EXPECT_GT(largest_load, 0.01) << "the legs carry the robot";
}

// A driver reads Present Position of every servo over the pty once the simulation has stopped on a
// sample: its raw values are the message's, and decode to the true angle within a count.
TEST(SensorLevelsGateway, ADriversPresentPositionIsThePublishedDecodedValue) {
  Rig rig(100.0);
  rig.start_bus();
  std::thread simulation([&] {
    for (int i = 0; i < 1500; ++i) {
      rig.step(false);
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    }
  });
  simulation.join();
  levels::SensorLevels message;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (message.sim_time_ns() != 1'500'000'000 && std::chrono::steady_clock::now() < deadline) {
    rig.robot().sensor_levels(message);  // the bus thread samples at its next tick
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(message.sim_time_ns(), 1'500'000'000);

  testing::SerialClient driver(rig.link(), rig.config().buses[0].baud_bps);
  for (const levels::ServoLevels& s : message.servos()) {
    // READ (0x02) Present Position (36), 2 bytes: FF FF ID 4 ERR P_L P_H CKSUM.
    const testing::Bytes reply = driver.transact(testing::p1_instruction(static_cast<uint8_t>(s.id()), 0x02, {36, 2}), 8, 1000);
    ASSERT_EQ(reply.size(), 8u) << "ID " << s.id();
    const int raw = reply[5] | (reply[6] << 8);
    EXPECT_EQ(raw, s.decoded().present_position_raw()) << "ID " << s.id();
    const double driver_rad = (raw - 2048) * kCount;  // e-Manual MX-28: 2048 at the centre
    EXPECT_DOUBLE_EQ(driver_rad, s.decoded().present_position_rad()) << "ID " << s.id();
    EXPECT_NEAR(driver_rad, s.truth().angle_rad(), kCount) << "ID " << s.id();
  }
}

// Wolfgang's four buses sample on their own threads: the robot's message waits until every bus has
// its new sample, so there is one message per sample period with all buses of the same step.
TEST(SensorLevelsGateway, ARobotWithSeveralBusesSendsOneMessagePerSample) {
  const RobotConfig config = load_robot("wolfgang", DOPPEL_ROBOTS_DIR);
  ASSERT_GT(config.buses.size(), 1u);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("doppel-levels-buses-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  Options options;
  options.buses.link_dir = dir.string();
  options.truth.sensor_levels_hz = 100.0;
  {
    RobotRuntime robot(config, 0, std::make_unique<body::KinematicBody>(), options);
    levels::SensorLevels message;
    EXPECT_TRUE(robot.sensor_levels(message)) << "the power-on samples";
    int messages = 0;
    for (int step = 1; step <= 1000; ++step) {
      robot.sense(int64_t{step} * 1'000'000);
      robot.bus(0).on_tick();
      if (step % 10 == 0) {
        EXPECT_FALSE(robot.sensor_levels(message)) << "bus 0 alone, step " << step;
      }
      for (std::size_t b = 1; b < robot.bus_count(); ++b) robot.bus(b).on_tick();
      if (!robot.sensor_levels(message)) continue;
      ++messages;
      EXPECT_EQ(message.sim_time_ns(), int64_t{step} * 1'000'000);
      for (const levels::ServoLevels& s : message.servos()) EXPECT_EQ(s.sim_time_ns(), message.sim_time_ns()) << s.name();
    }
    EXPECT_EQ(messages, 100);
    std::size_t servos = 0;
    for (const BusConfig& bus : config.buses) {
      for (const DeviceConfig& device : bus.devices) {
        if (device.firmware == dynamixel::Protocol::kV2 &&
            dynamixel::p2_model_spec(device.model).kind == dynamixel::P2DeviceKind::kServo) {
          ++servos;
        }
      }
    }
    EXPECT_EQ(static_cast<std::size_t>(message.servos_size()), servos);
    EXPECT_EQ(message.imus_size(), 1);
    EXPECT_EQ(message.feet_size(), 2);
  }
  std::filesystem::remove_all(dir);
}

// A feed's pass hands each new sample to its sink once, as one message per robot that survives
// serialization; through the truth transport (UDP to loopback only) it arrives as topic
// `sensor_levels` of robot 0.
TEST(SensorLevelsGateway, TheFeedHandsEachNewSampleOnceAndPublishesItOnTheTruthTransport) {
  Rig rig(100.0);
  SensorLevelsFeed feed({&rig.robot()});
  std::vector<std::string> sent;
  const SensorLevelsFeed::Sink sink = [&](std::size_t robot, const levels::SensorLevels& message) {
    EXPECT_EQ(robot, 0u);
    sent.push_back(message.SerializeAsString());
  };
  EXPECT_EQ(feed.poll(sink), 1u) << "the power-on sample";
  EXPECT_EQ(feed.poll(sink), 0u) << "nothing new";
  for (int i = 0; i < 10; ++i) rig.step(true);
  EXPECT_EQ(feed.poll(sink), 1u);
  ASSERT_EQ(sent.size(), 2u);
  levels::SensorLevels parsed;
  ASSERT_TRUE(parsed.ParseFromString(sent[1]));
  EXPECT_EQ(parsed.sim_time_ns(), 10'000'000);
  EXPECT_EQ(parsed.servos_size(), 20);
  EXPECT_EQ(parsed.feet_size(), 2);

  truth::UdpReceiver receiver(0);
  truth::TransportOptions transport_options;
  transport_options.iceoryx = false;
  transport_options.udp_base_port = receiver.port();
  truth::Transport transport(transport_options);
  for (int i = 0; i < 10; ++i) rig.step(true);
  EXPECT_EQ(feed.publish(transport), 1u);
  const std::optional<truth::Datagram> datagram = receiver.receive(10.0);
  ASSERT_TRUE(datagram);
  EXPECT_EQ(datagram->robot, 0u);
  EXPECT_EQ(datagram->topic, "sensor_levels");
  ASSERT_TRUE(parsed.ParseFromString(datagram->payload));
  EXPECT_EQ(parsed.sim_time_ns(), 20'000'000);
  EXPECT_EQ(parsed.robot_name(), rig.config().name);
  EXPECT_EQ(feed.messages(), 3u);
}

// End to end: the real doppel (the default robot, FUmanoid 2011 with RX servos, held until torque
// on the ODE world) publishes sensor levels over UDP to loopback; a Protocol 1.0 driver reads every
// Present Position over the pty between two messages. The held robot trembles by at most 2 units
// (physics_integration_test), so the driver's value is the published decoded value within 2 units,
// and every decoded angle is its true angle within one unit (RX-28/64: 300/1024 deg).
TEST(SensorLevelsDoppel, ADriverReadsWhatTheSensorLevelsTopicSays) {
  truth::UdpReceiver receiver(0);
  testing::DoppelProcess doppel({"--timing", "fast", "--no-truth-iceoryx", "--truth-udp-port",
                                 std::to_string(receiver.port()), "--sensor-levels", "50"});
  const double unit_rad = 300.0 / 1024 * kPi / 180;
  auto next = [&] {
    levels::SensorLevels message;
    for (int i = 0; i < 100; ++i) {
      const std::optional<truth::Datagram> datagram = receiver.receive(30.0);
      if (!datagram) break;
      if (datagram->topic == "sensor_levels" && message.ParseFromString(datagram->payload)) return message;
    }
    ADD_FAILURE() << "no sensor_levels message: " << doppel.output();
    return message;
  };
  const levels::SensorLevels before = next();
  ASSERT_EQ(before.servos_size(), 21);
  testing::SerialClient driver(doppel.link(), 1'000'000);
  std::vector<int> raw;
  for (const levels::ServoLevels& s : before.servos()) {
    const testing::Bytes reply = driver.transact(testing::p1_instruction(static_cast<uint8_t>(s.id()), 0x02, {36, 2}), 8, 1000);
    ASSERT_EQ(reply.size(), 8u) << "ID " << s.id();
    raw.push_back(reply[5] | (reply[6] << 8));
  }
  const levels::SensorLevels after = next();
  ASSERT_EQ(after.servos_size(), 21);
  EXPECT_GT(after.sim_time_ns(), before.sim_time_ns());
  for (int i = 0; i < after.servos_size(); ++i) {
    const levels::ServoLevels& s = after.servos(i);
    EXPECT_NEAR(raw[i], s.decoded().present_position_raw(), 2) << "ID " << s.id();
    EXPECT_NEAR((raw[i] - 512) * unit_rad, s.decoded().present_position_rad(), 2 * unit_rad) << "ID " << s.id();
    EXPECT_NEAR(s.decoded().present_position_rad(), s.truth().angle_rad(), unit_rad) << "ID " << s.id();
  }
  ASSERT_EQ(after.imus_size(), 1);
  EXPECT_EQ(after.imus(0).model(), "FUMANOID-IMU");
  ASSERT_EQ(after.feet_size(), 2);
  doppel.stop(2);
  EXPECT_NE(doppel.output().find("sensor levels: "), std::string::npos) << doppel.output();
}

}  // namespace
}  // namespace doppel::gateway
