// End-to-end with a body from a URDF: the real doppel serving tests/urdf/data/test-biped.textproto
// (figure { urdf { file: "biped.urdf" ... } }, convex-hull feet from an STL and a DAE). Its six
// RX-64 answer on the bus, and with torque on it stands: level, its foot boards carrying its
// weight. Both engines.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <string>

#include "doppel_process.h"
#include "gateway/robot_config.h"
#include "reference_client.h"
#include "sim_time.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 1000000;
constexpr double kRobotMassKg = 2.8;  // tests/urdf/data/biped.urdf: sum of its <inertial> masses
constexpr double kGravity = 9.80665;
const std::string kRobotFile = std::string(DOPPEL_URDF_TEST_DATA) + "/test-biped.textproto";

int16_t word(const Bytes& reply, std::size_t offset) {
  return static_cast<int16_t>(reply.at(offset) | (reply.at(offset + 1) << 8));
}

// Simulation time from the IMU's Sample Counter (48, +1 per 20 ms), as physics_integration_test.

class UrdfRobot : public ::testing::TestWithParam<const char*> {};

TEST_P(UrdfRobot, ServosAnswerAndItStands) {
  DoppelProcess doppel({"--robot", kRobotFile, "--physics", GetParam(), "--timing", "fast"});
  SerialClient client(doppel.link(), kBaud);
  for (uint8_t id = 1; id <= 6; ++id) {
    const Bytes reply = client.transact(p1_instruction(id, 0x01, {}), 6);  // PING
    ASSERT_EQ(reply.size(), 6u) << "ID " << int(id);
    EXPECT_EQ(reply.at(4), 0) << "ID " << int(id);  // no error bits
    const Bytes model = client.transact(p1_instruction(id, 0x02, {0, 2}), 8);
    ASSERT_EQ(model.size(), 8u);
    EXPECT_EQ(word(model, 5), 64) << "ID " << int(id);  // RX-64's Model Number (docs/devices.md)
  }
  client.send(p1_instruction(0xFE, 0x03, {24, 1}));  // Torque Enable on every servo
  wait_sim_time(client, 2.0);

  // IMU pitch / roll (26, 0.1 mrad) and both foot boards' totals (34, 0.01 N), docs/devices.md;
  // the mean of twenty readings one IMU sample (20 ms of simulation time) apart (ODE's contacts
  // jitter by a few newtons from one step to the next and rock slowly: ten back-to-back readings once
  // averaged 15 % low).
  double pitch = 0.0, roll = 0.0, feet = 0.0;
  for (int i = 0; i < 20; ++i) {
    wait_sim_time(client, kImuSamplePeriodS);
    const Bytes imu = client.transact(p1_instruction(100, 0x02, {26, 4}), 10);
    const Bytes left = client.transact(p1_instruction(101, 0x02, {34, 2}), 8);
    const Bytes right = client.transact(p1_instruction(102, 0x02, {34, 2}), 8);
    ASSERT_EQ(imu.size(), 10u);
    ASSERT_EQ(left.size(), 8u);
    ASSERT_EQ(right.size(), 8u);
    pitch += word(imu, 5) * 1e-4 * 180.0 / M_PI / 20.0;
    roll += word(imu, 7) * 1e-4 * 180.0 / M_PI / 20.0;
    feet += (static_cast<uint16_t>(word(left, 5)) + static_cast<uint16_t>(word(right, 5))) * 0.01 / 20.0;
  }
  // Level within 3 deg (tests/urdf's BipedStandsOnItsHullFeet: about 1 deg of lean from the servos'
  // compliance), the weight on the feet within 10 % (5 % there, averaged over 100 steps).
  EXPECT_LT(std::fabs(pitch), 3.0) << pitch;
  EXPECT_LT(std::fabs(roll), 3.0) << roll;
  EXPECT_NEAR(feet, kRobotMassKg * kGravity, 0.1 * kRobotMassKg * kGravity);
}

TEST(UrdfRobotFile, ABrokenUrdfIsRefusedNamingTheFileAndTheElement) {
  // gateway's loader runs the URDF import: a mesh that is not there stops the robot file.
  const std::string text =
      "name: \"r\"\nbus { baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: \"RX-64\" } }\n"
      "figure {\n  urdf { file: \"missing_mesh.urdf\" }\n}\n";
  try {
    gateway::parse_robot(text, std::string(DOPPEL_URDF_TEST_DATA) + "/robot.textproto");
    ADD_FAILURE() << "accepted";
  } catch (const std::exception& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("robot.textproto:4:"), std::string::npos) << what;
    EXPECT_NE(what.find("missing_mesh.urdf: link 'shell'"), std::string::npos) << what;
    EXPECT_NE(what.find("no_such_mesh.stl"), std::string::npos) << what;
  }
}

INSTANTIATE_TEST_SUITE_P(Engines, UrdfRobot, ::testing::Values("ode", "bullet"));

}  // namespace
}  // namespace doppel::testing
