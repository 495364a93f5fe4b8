// End-to-end: data/robots/op3 (20 XM430-W350 and the OpenCR on one Protocol 2.0 bus at 2 Mbps) driven
// over its pty the way the OP3's stack drives the real bus, in the order its sources give:
// op3_manager.cpp (ROBOTIS-GIT/ROBOTIS-OP3 commit 3bc2bd5) writes dynamixel_power (24) = 1 to the
// OpenCR; robotis_controller (ROBOTIS-GIT/ROBOTIS-Framework commit 288e048, initializeDevice) then
// goes through op3_manager/config/dxl_init_OP3.yaml joint by joint (reads Torque Enable, reads each
// EEPROM item and writes it only when it differs, writes the RAM gains), points each servo's
// Indirect Address 1..10 at the bulk-read items of OP3.robot (present_position, position_p_gain,
// position_i_gain, position_d_gain; robot.cpp maps them to Indirect Data 1) and enables its torque.
// Its joints live in a std::map keyed by joint name, so every group packet lists them in
// alphabetical order. Every 8 ms (OP3.robot control_cycle) it sends one BULK READ (10 bytes from
// Indirect Data 1 of each servo, 20 bytes from the OpenCR's button (30) to yaw (48)) and one SYNC
// WRITE of Goal Position (116, 4 bytes). Values come from the manuals, the stack's files and physics.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <thread>
#include <vector>

#include "camera/camera_config.h"
#include "camera/lens.h"
#include "controlled_doppel.h"
#include "cycle_stats.h"
#include "doppel_process.h"
#include "gateway/robot_config.h"
#include "held_pose.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 2000000;  // OP3.robot
constexpr uint8_t kRead = 0x02, kWrite = 0x03, kSyncWrite = 0x83, kBulkRead = 0x92, kBroadcast = 0xFE;
// XM430-W350 (reference §3.7, XM430-W350.device).
constexpr uint16_t kReturnDelay = 9, kOperatingMode = 11, kMaxPosition = 48, kMinPosition = 52, kShutdown = 63;
constexpr uint16_t kTorqueEnable = 64, kDGain = 80, kIGain = 82, kPGain = 84, kGoalPosition = 116;
constexpr uint16_t kRealtimeTick = 120, kPresentPosition = 132, kIndirectAddress1 = 168, kIndirectData1 = 224;
// OpenCR (OPEN-CR.device).
constexpr uint8_t kOpenCr = 200;
constexpr uint16_t kDxlPower = 24, kButton = 30, kOpenCrBlock = 20;  // button .. yaw
constexpr uint16_t kStackPGain = 800;                                 // dxl_init_OP3.yaml
constexpr double kUnitsPerDeg = 4096.0 / 360.0;  // XM430-W350.device: 2048 = 0 rad, 0..4095 = -pi..pi

struct Joint {
  const char* name;
  uint8_t id;
  double initial_deg;  // data/robots/op3.textproto: walking-ready legs, ini_pose.yaml arms and head
  bool arm;            // dxl_init_OP3.yaml sets Shutdown 56 on the arms
};
// OP3.robot's joints in robotis_controller's order (std::map by name).
constexpr std::array<Joint, 20> kJoints{{
    {"head_pan", 19, 0.0, false},     {"head_tilt", 20, -10.0, false},  {"l_ank_pitch", 16, 38.4, false},
    {"l_ank_roll", 18, -2.3, false},  {"l_el", 6, -45.0, true},         {"l_hip_pitch", 12, -25.9, false},
    {"l_hip_roll", 10, -2.3, false},  {"l_hip_yaw", 8, 0.0, false},     {"l_knee", 14, 64.3, false},
    {"l_sho_pitch", 2, -15.0, true},  {"l_sho_roll", 4, 45.0, true},    {"r_ank_pitch", 15, -38.4, false},
    {"r_ank_roll", 17, 2.3, false},   {"r_el", 5, 45.0, true},          {"r_hip_pitch", 11, 25.9, false},
    {"r_hip_roll", 9, 2.3, false},    {"r_hip_yaw", 7, 0.0, false},     {"r_knee", 13, -64.3, false},
    {"r_sho_pitch", 1, 15.0, true},   {"r_sho_roll", 3, -45.0, true},
}};
// The bulk-read items behind Indirect Data 1..10: present_position, position_p_gain,
// position_i_gain, position_d_gain (OP3.robot order).
constexpr std::array<uint16_t, 10> kIndirectTargets{132, 133, 134, 135, 84, 85, 82, 83, 80, 81};

int16_t i16_at(const Bytes& b, std::size_t offset) { return static_cast<int16_t>(b.at(offset) | (b.at(offset + 1) << 8)); }

Bytes read_params(uint16_t address, uint16_t length) {
  Bytes p = le16(address);
  const Bytes l = le16(length);
  p.insert(p.end(), l.begin(), l.end());
  return p;
}

Bytes write_params(uint16_t address, uint32_t value, int size) {
  Bytes p = le16(address);
  for (int i = 0; i < size; ++i) p.push_back(static_cast<uint8_t>(value >> (8 * i)));
  return p;
}

// The OpenCR's 20-byte block, decoded.
struct OpenCrBlock {
  uint8_t button = 0, voltage = 0;
  std::array<int16_t, 3> gyro{}, acc{}, rpy{};
};
OpenCrBlock decode(const Bytes& b) {
  OpenCrBlock o;
  o.button = b.at(0);
  o.voltage = b.at(1);
  for (std::size_t k = 0; k < 3; ++k) {
    o.gyro[k] = i16_at(b, 2 + 2 * k);
    o.acc[k] = i16_at(b, 8 + 2 * k);
    o.rpy[k] = i16_at(b, 14 + 2 * k);
  }
  return o;
}

// The robot file asks for 100 solver sweeps: the OP3's light links need them to stand (tests/physics/op3_test.cpp).
class Op3Bus {
 public:
  explicit Op3Bus(std::vector<std::string> args) : doppel_(with_control(std::move(args))), client_(doppel_.link(), kBaud) {}

  SerialClient& client() { return client_; }

  // One instruction with one status; its parameters (empty, and a failure, on anything but a
  // well-formed status of `id` with error 0 and `length` parameters).
  Bytes transact(uint8_t id, uint8_t instruction, const Bytes& params, std::size_t length) {
    const auto s = parse_p2_statuses(transact_p2(client_, p2_instruction(id, instruction, params), 1, 1000));
    if (!s || s->size() != 1 || (*s)[0].id != id || (*s)[0].error != 0 || (*s)[0].params.size() != length) {
      ADD_FAILURE() << "no " << length << "-byte status from ID " << int(id) << " to instruction " << int(instruction);
      return {};
    }
    return (*s)[0].params;
  }
  Bytes read(uint8_t id, uint16_t address, uint16_t length) { return transact(id, kRead, read_params(address, length), length); }
  void write(uint8_t id, uint16_t address, uint32_t value, int size) {
    EXPECT_EQ(client_.transact(p2_instruction(id, kWrite, write_params(address, value, size)), 11, 1000), p2_status(id, 0))
        << "WRITE " << address << " to ID " << int(id);
  }

  // op3_manager and robotis_controller's start-up, as the file comment describes; every status
  // compared byte for byte. The simulation is paused meanwhile (doppel-ctl), so that every joint is
  // stiff from the same simulated instant however long its ~420 transactions take: the handler lets
  // go 1 s of simulation time after the first torque (docs/physics.md), and on a loaded machine the
  // last joints could still be limp then.
  void start_like_the_stack() {
    expect_ctl(doppel_, "pause");
    write(kOpenCr, kDxlPower, 1, 1);
    for (const Joint& j : kJoints) {  // dxl_init_OP3.yaml: its keys in file order, items alphabetical
      EXPECT_EQ(read(j.id, kTorqueEnable, 1), Bytes{0}) << j.name;
      EXPECT_EQ(read(j.id, kMaxPosition, 4), le32(4095)) << j.name;  // EEPROM, as in the file: no write
      EXPECT_EQ(read(j.id, kMinPosition, 4), le32(0)) << j.name;
      EXPECT_EQ(read(j.id, kOperatingMode, 1), Bytes{3}) << j.name;
      write(j.id, kDGain, 0, 2);  // RAM: always written
      write(j.id, kIGain, 0, 2);
      write(j.id, kPGain, kStackPGain, 2);
      EXPECT_EQ(read(j.id, kReturnDelay, 1), Bytes{1}) << j.name;  // the robot file's EEPROM
      if (j.arm) {
        EXPECT_EQ(read(j.id, kShutdown, 1), Bytes{56}) << j.name;
      }
    }
    for (const Joint& j : kJoints) {
      EXPECT_EQ(read(j.id, kTorqueEnable, 1), Bytes{0}) << j.name;
      for (std::size_t k = 0; k < kIndirectTargets.size(); ++k) {
        const auto address = static_cast<uint16_t>(kIndirectAddress1 + 2 * k);
        // Factory Indirect Address n = 224 + n - 1 (e-Manual): differs, so the stack writes it.
        EXPECT_EQ(read(j.id, address, 2), le16(static_cast<uint16_t>(kIndirectData1 + k))) << j.name;
        write(j.id, address, kIndirectTargets[k], 2);
      }
      write(j.id, kTorqueEnable, 1, 1);
    }
    expect_ctl(doppel_, "resume");
  }

  // Waits for `seconds` of simulation time by servo 1's Realtime Tick (ms, wraps at 32768).
  void wait_sim_time(double seconds) {
    auto tick = [&] {
      const Bytes t = read(1, kRealtimeTick, 2);
      return t.size() == 2 ? static_cast<int>(t[0] | (t[1] << 8)) : 0;
    };
    const int start = tick();
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while ((tick() - start + 32768) % 32768 < static_cast<int>(seconds * 1000.0)) {
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the simulation did not advance " << seconds << " s";
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }

  int32_t present_position(uint8_t id) {
    const Bytes b = read(id, kPresentPosition, 4);
    return b.size() == 4 ? le32_at(b, 0) : -1;
  }

  OpenCrBlock open_cr() {
    const Bytes b = read(kOpenCr, kButton, kOpenCrBlock);
    return b.size() == kOpenCrBlock ? decode(b) : OpenCrBlock{};
  }

 private:
  static std::vector<std::string> with_control(std::vector<std::string> args) {
    args.insert(args.end(), {"--viewer", "0"});
    return args;
  }
  DoppelProcess doppel_;
  SerialClient client_;
};

int32_t initial_units(const Joint& j) { return static_cast<int32_t>(std::lround(2048.0 + j.initial_deg * kUnitsPerDeg)); }

TEST(Op3, IsListed) {
  auto [code, list] = run_command(doppel_executable() + " --list-robots");
  EXPECT_EQ(code, 0);
  EXPECT_NE(list.find("op3             ROBOTIS OP3: 20 XM430-W350, OpenCR (200)"), std::string::npos) << list;
}

// The head camera as op3_bringup.launch starts usb_cam: 1280 x 720 at 30 fps, pinhole with
// MuJoCo Menagerie's vertical field of view of 43.3 deg (yuyv: Doppel does not encode mjpeg).
TEST(Op3, CameraIsTheC920AsTheStackOpensIt) {
  const gateway::RobotConfig sut = gateway::load_robot("op3", DOPPEL_ROBOTS_DIR);
  ASSERT_EQ(sut.cameras.size(), 1u);
  const camera::CameraConfig& c = sut.cameras[0].config;
  EXPECT_EQ(c.width_px, 1280);
  EXPECT_EQ(c.height_px, 720);
  EXPECT_DOUBLE_EQ(c.fps, 30.0);
  EXPECT_EQ(c.format, camera::PixelFormat::kYuyv);
  EXPECT_EQ(c.lens.model, camera::LensModel::kPinhole);
  EXPECT_NEAR(2.0 * std::atan(360.0 / c.lens.fy_px) * 180.0 / M_PI, 43.3, 0.05);
}

// (b) Held in its initial pose until the stack enables torque: the servos read the ready pose in
// the stack's units (2048 = 0 rad, + = the URDF axis), nothing moves, the OpenCR lies level.
TEST(Op3, HeldInTheReadyPoseUntilTheStackEnablesTorque) {
  Op3Bus bus({"--robot", "op3", "--timing", "fast"});
  // The handler's hold (physics::World, a stiff velocity drive per joint) gives a little under the
  // arms' weight while the robot settles: within 2 deg (23 units) of the ready pose. How far it
  // has given at the first reads depends on how much simulation time passed before they ran (on a
  // loaded machine, more), so they get the same bound. From then on nothing moves: seven units
  // (0.6 deg), as for fumanoid-x430's held servos.
  constexpr int32_t kGiveUnits = 23;
  for (const Joint& j : kJoints) EXPECT_NEAR(bus.present_position(j.id), initial_units(j), kGiveUnits) << j.name;
  bus.wait_sim_time(0.5);
  const OpenCrBlock settled = bus.open_cr();
  std::vector<int32_t> settled_positions;
  for (const Joint& j : kJoints) settled_positions.push_back(bus.present_position(j.id));
  bus.wait_sim_time(2.5);
  const OpenCrBlock held = bus.open_cr();
  for (std::size_t i = 0; i < kJoints.size(); ++i) {
    EXPECT_NEAR(settled_positions[i], initial_units(kJoints[i]), kGiveUnits) << kJoints[i].name;
    EXPECT_NEAR(bus.present_position(kJoints[i].id), settled_positions[i], 7) << kJoints[i].name;
  }
  // Roll and pitch in 0.1 deg: level within held_pose.h's 0.5 deg, still within one count.
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_LE(std::abs(held.rpy[k]), kHeldLevelDeg * 10.0) << k;
    EXPECT_NEAR(held.rpy[k], settled.rpy[k], 1) << k;
  }
  EXPECT_EQ(held.voltage, 125);  // (12.0 V + 0.5) x 10, the firmware's formula (docs/devices.md)
}

// (a) Stands with torque on at the stack's gains on both engines; the OpenCR reads a robot at rest
// within the MPU-9250's datasheet offsets: zero-rate offset +-5 deg/s (82 counts at 16.4 per
// deg/s), zero-g offset +-60 mg on x and y, +-80 mg on z (983 / 1311 counts at 16384 per g), and
// so roll and pitch within asin(0.06) = 3.4 deg of level.
class Op3Stands : public ::testing::TestWithParam<const char*> {};

TEST_P(Op3Stands, AtTheStackGainsAndTheOpenCrReadsItAtRest) {
  Op3Bus bus({"--robot", "op3", "--physics", GetParam(), "--timing", "fast"});
  bus.start_like_the_stack();
  bus.wait_sim_time(3.0);
  for (const Joint& j : kJoints) {
    ASSERT_EQ(bus.read(j.id, kTorqueEnable, 1), Bytes{1}) << j.name;
    // Still in the ready pose: within 3 deg (34 units) of where it started.
    EXPECT_NEAR(bus.present_position(j.id), initial_units(j), 34) << j.name;
  }
  int worst_gyro = 0;
  std::array<double, 3> acc{};
  std::array<double, 2> rp{};
  constexpr int kReads = 10;
  for (int i = 0; i < kReads; ++i) {
    const OpenCrBlock o = bus.open_cr();
    for (std::size_t k = 0; k < 3; ++k) {
      worst_gyro = std::max(worst_gyro, std::abs(static_cast<int>(o.gyro[k])));
      acc[k] += o.acc[k] / static_cast<double>(kReads);
    }
    for (std::size_t k = 0; k < 2; ++k) rp[k] += o.rpy[k] / static_cast<double>(kReads);
    EXPECT_EQ(o.button, 0);
    EXPECT_EQ(o.voltage, 125);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_LE(worst_gyro, 82);
  EXPECT_NEAR(acc[0], 0.0, 983.0);
  EXPECT_NEAR(acc[1], 0.0, 983.0);
  EXPECT_NEAR(acc[2], 16384.0, 1311.0);
  EXPECT_NEAR(rp[0], 0.0, 34.0);
  EXPECT_NEAR(rp[1], 0.0, 34.0);
  std::printf("op3 standing on %s: gyro worst %d counts, acc %.0f %.0f %.0f counts, roll %.1f pitch %.1f deg\n",
              GetParam(), worst_gyro, acc[0], acc[1], acc[2], rp[0] / 10.0, rp[1] / 10.0);
}

INSTANTIATE_TEST_SUITE_P(Engines, Op3Stands, ::testing::Values("ode", "bullet"),
                         [](const ::testing::TestParamInfo<const char*>& param) { return std::string(param.param); });

// (c) The stack's cycle for 60 s in wire mode with physics (ODE): one BULK READ and one SYNC WRITE
// every 8 ms. The head pans +-200 units (17.6 deg) in a 2 s sine; the other joints hold.
TEST(Op3, StackCycleOfEightMillisecondsForSixtySecondsInWireMode) {
  Op3Bus bus({"--robot", "op3", "--timing", "wire"});
  bus.start_like_the_stack();
  std::array<int32_t, kJoints.size()> hold{};
  for (std::size_t i = 0; i < kJoints.size(); ++i) hold[i] = bus.present_position(kJoints[i].id);

  Bytes bulk;
  for (const Joint& j : kJoints) {
    bulk.push_back(j.id);
    const Bytes p = read_params(kIndirectData1, 10);
    bulk.insert(bulk.end(), p.begin(), p.end());
  }
  bulk.push_back(kOpenCr);
  const Bytes p = read_params(kButton, kOpenCrBlock);
  bulk.insert(bulk.end(), p.begin(), p.end());
  const Bytes bulk_read = p2_instruction(kBroadcast, kBulkRead, bulk);
  // Gains behind Indirect Data 5..10: P 800, I 0, D 0.
  const Bytes gains = {0x20, 0x03, 0, 0, 0, 0};

  constexpr int kCycles = 7500;  // 60 s of 8 ms
  constexpr auto kPeriod = std::chrono::milliseconds(8);
  CycleStats stats(8.0, kCycles);
  OpenCrBlock last_open_cr;
  auto next = std::chrono::steady_clock::now();
  for (int cycle = 0; cycle < kCycles; ++cycle) {
    const auto start = std::chrono::steady_clock::now();
    // A starved client is slow, not wrong: a long timeout.
    const Bytes reply = transact_p2(bus.client(), bulk_read, kJoints.size() + 1, 1000);
    const auto statuses = parse_p2_statuses(reply);
    std::string why;
    if (!statuses || statuses->size() != kJoints.size() + 1) {
      why = "not 21 well-formed statuses (CRC, header, length)";
    }
    for (std::size_t i = 0; why.empty() && i < kJoints.size(); ++i) {
      const P2Status& s = (*statuses)[i];
      if (s.id != kJoints[i].id || s.error != 0 || s.params.size() != 10) {
        why = "status " + std::to_string(i) + ": ID " + std::to_string(s.id) + ", error " + std::to_string(s.error);
      } else if (Bytes(s.params.begin() + 4, s.params.end()) != gains) {
        why = std::string(kJoints[i].name) + ": gains are not 800/0/0";
      } else if (le32_at(s.params, 0) < 0 || le32_at(s.params, 0) > 4095) {
        why = std::string(kJoints[i].name) + ": Present Position " + std::to_string(le32_at(s.params, 0));
      }
    }
    if (why.empty()) {
      const P2Status& s = statuses->back();
      if (s.id != kOpenCr || s.error != 0 || s.params.size() != kOpenCrBlock) {
        why = "OpenCR status: ID " + std::to_string(s.id) + ", error " + std::to_string(s.error);
      } else {
        // Button and voltage are determined; the IMU's values depend on the robot's motion (see
        // below) and are checked by the status' CRC, ID and length only.
        const OpenCrBlock o = decode(s.params);
        last_open_cr = o;
        if (o.button != 0 || o.voltage != 125) {
          why = "OpenCR button " + std::to_string(o.button) + ", voltage " + std::to_string(o.voltage);
        }
      }
    }
    const bool ok = why.empty();
    Bytes sync = write_params(kGoalPosition, 4, 2);
    const auto pan = static_cast<int32_t>(std::lround(200.0 * std::sin(2.0 * M_PI * cycle / 250.0)));  // 2 s
    for (std::size_t i = 0; i < kJoints.size(); ++i) {
      sync.push_back(kJoints[i].id);
      const Bytes goal = le32(hold[i] + (kJoints[i].id == 19 ? pan : 0));
      sync.insert(sync.end(), goal.begin(), goal.end());
    }
    bus.client().send(p2_instruction(kBroadcast, kSyncWrite, sync));
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    stats.add(ms, ok);
    if (!ok) {
      ADD_FAILURE() << "cycle " << cycle << ": " << reply.size() << " bytes, not the expected BULK READ answer: " << why;
      if (stats.errors() > 10) break;
      bus.client().drain(20);
    }
    next += kPeriod;
    if (std::chrono::steady_clock::now() > next) next = std::chrono::steady_clock::now();
    std::this_thread::sleep_until(next);
  }
  EXPECT_TRUE(bus.client().drain(50).empty());  // SYNC WRITE has no status
  EXPECT_EQ(stats.errors(), 0);
  ASSERT_GT(stats.cycles(), 0);
  RecordProperty("cycles", static_cast<int>(stats.cycles()));
  RecordProperty("overruns", static_cast<int>(stats.over_period()));
  std::printf("op3 cycle (BULK READ + SYNC WRITE): %s\n", stats.summary().c_str());
  // Still standing after the stack's start-up (it enables its servos one at a time; the handler
  // hands the robot over joint by joint, physics::WorldOptions::hold_hand_over_s) and 60 s of
  // cycles: the OpenCR level within asin(0.06) = 3.4 deg, as in Op3Stands.
  std::printf("op3 after 60 s: OpenCR acc z %d counts, roll %.1f, pitch %.1f deg\n", last_open_cr.acc[2],
              last_open_cr.rpy[0] / 10.0, last_open_cr.rpy[1] / 10.0);
  EXPECT_LE(std::abs(last_open_cr.rpy[0]), 34);
  EXPECT_LE(std::abs(last_open_cr.rpy[1]), 34);
  // The last goals arrived: every servo holds its goal register (the head its last pan).
  EXPECT_EQ(bus.read(1, kGoalPosition, 4), le32(hold[18]));
}

}  // namespace
}  // namespace doppel::testing
