// A bus thread publishes its servo table for the viewer without allocating: after setup,
// BusRuntime::on_tick (every 10 ms; the table every 10th tick) calls no operator new while an
// HTTP-side reader copies the table at the same time, and the table lists the bus' servos under
// their IDs, names and models. Its own executable, because it replaces the global operator new.
#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <thread>
#include <unistd.h>

#include "allocation_counter.h"
#include "body/kinematic_body.h"
#include "dynamixel/models.h"
#include "dynamixel/protocol1.h"
#include "faults/fault.h"
#include "dynamixel/protocol2_models.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "robot_runtime.h"

namespace doppel::gateway {
namespace {

TEST(BusRuntimeAllocations, PublishingTheServoTableAllocatesNothingAndListsTheServos) {
  const RobotConfig robot = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  ASSERT_FALSE(robot.buses.empty());
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("doppel-bus-alloc-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  body::KinematicBody body;
  const Options options;
  BusRuntime sut(robot.buses[0], 0, body, (dir / "ttyDXL0").string(), options);

  std::atomic<bool> done{false};
  std::atomic<int> reads{0};
  std::thread reader([&] {  // an HTTP thread polling /api/buses
    while (!done.load()) {
      const contract::BusTable table = sut.servo_table();
      EXPECT_FALSE(table.servos.empty());
      reads.fetch_add(1);
    }
  });
  for (int tick = 0; tick < 200; ++tick) {  // 2 s of bus ticks: 20 tables
    doppel::testing::count_allocations_on_this_thread(true);
    sut.on_tick();
    doppel::testing::count_allocations_on_this_thread(false);
  }
  while (reads.load() < 3) std::this_thread::yield();
  done = true;
  reader.join();
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "over 200 bus ticks";

  const contract::BusTable table = sut.servo_table();
  EXPECT_EQ(table.link, (dir / "ttyDXL0").string());
  std::size_t row = 0;
  for (const DeviceConfig& device : robot.buses[0].devices) {
    const bool servo = device.firmware == dynamixel::Protocol::kV2
                           ? dynamixel::p2_model_spec(device.model).kind == dynamixel::P2DeviceKind::kServo
                           : dynamixel::model_spec(device.model).kind == dynamixel::DeviceKind::kServo;
    if (!servo) continue;  // the IMU and foot boards have no row
    ASSERT_LT(row, table.servos.size());
    EXPECT_EQ(table.servos[row].id, device.id);
    EXPECT_EQ(table.servos[row].name, device.name);
    EXPECT_EQ(table.servos[row].model, device.model);
    EXPECT_FALSE(table.servos[row].torque) << "power-on: torque off";
    EXPECT_GE(table.servos[row].goal_position, 0);
    ++row;
  }
  EXPECT_EQ(row, table.servos.size());
  std::filesystem::remove_all(dir);
}

// With sensor levels on (--sensor-levels), the bus thread also copies every sensor's registers and
// the feedback they came from into its sample at 100 Hz of simulation time, still without allocating.
TEST(BusRuntimeAllocations, SamplingSensorLevelsAllocatesNothing) {
  const RobotConfig robot = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("doppel-levels-alloc-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  body::KinematicBody body;
  Options options;
  options.truth.sensor_levels_hz = 100.0;
  BusRuntime sut(robot.buses[0], 0, body, (dir / "ttyDXL0").string(), options);
  int samples = 0;
  for (int tick = 0; tick < 200; ++tick) {  // 200 ms of simulation, one bus tick per step
    doppel::testing::count_allocations_on_this_thread(true);
    sut.sense(int64_t{tick} * 1'000'000, 0.0);
    sut.on_tick();
    const bool fresh = sut.update_sensor_levels();
    doppel::testing::count_allocations_on_this_thread(false);
    if (fresh) {
      ++samples;
      EXPECT_EQ(sut.sensor_levels().sim_time_ns % 10'000'000, 0);
    }
  }
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "over 200 steps";
  EXPECT_EQ(samples, 20);
  EXPECT_FALSE(sut.sensor_levels_layout().servos.empty());
  std::filesystem::remove_all(dir);
}

// Every fault kind active at once (docs/faults.md): the bus thread applies them to the feedback and
// to the statuses it sends, the simulation thread to the drive, and neither allocates.
TEST(BusRuntimeAllocations, ApplyingEveryFaultAllocatesNothing) {
  const RobotConfig robot = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("doppel-faults-alloc-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  body::KinematicBody body;
  const Options options;
  BusRuntime sut(robot.buses[0], 0, body, (dir / "ttyDXL0").string(), options);
  faults::FaultTable table;
  uint32_t number = 0;
  for (const faults::FaultKindInfo& kind : faults::fault_kinds()) {
    faults::Fault& f = table.faults[table.count++];
    f.number = ++number;
    f.spec.kind = kind.kind;
    f.spec.bus = kind.scope == faults::FaultScope::kRobot ? -1 : 0;
    f.spec.id = kind.scope == faults::FaultScope::kRobot ? -1
                : kind.scope == faults::FaultScope::kBus ? (kind.kind == faults::FaultKind::kCollision ? 30 : -1)
                : kind.scope == faults::FaultScope::kSensor ? (kind.name.substr(0, 3) == "imu" ? 100 : 101)
                : kind.kind == faults::FaultKind::kDead ? 2
                                                        : 1;
    f.spec.value = kind.value_field.empty() ? 0.0 : kind.value_max / 2;
    f.spec.rate = kind.needs_rate ? 0.5 : 0.0;
    ASSERT_EQ(faults::check(f.spec), "") << kind.name;
  }
  sut.set_faults(table);

  dynamixel::StatusPacket status;
  ASSERT_TRUE(dynamixel::encode_protocol1_status(1, 0, nullptr, 0, status));
  const dynamixel::OutgoingStatus outgoing{&status, 1, 0, false, false, 0, false};
  dynamixel::InstructionPacket ping;
  ping.id = 1;
  ping.instruction = dynamixel::instruction::kPing;
  std::size_t answered = 0;
  for (int tick = 0; tick < 200; ++tick) {
    doppel::testing::count_allocations_on_this_thread(true);
    sut.drive(0.001);
    sut.sense(int64_t{tick} * 1'000'000, 0.0);
    sut.on_tick();
    answered += sut.impair(ping, {&outgoing, 1}).size();
    doppel::testing::count_allocations_on_this_thread(false);
  }
  EXPECT_EQ(doppel::testing::counted_allocations(), 0u) << "over 200 steps with every fault active";
  EXPECT_GT(answered, 0u);
  EXPECT_LT(answered, 200u) << "drop at 0.5 lost some";
  const contract::BusTable servo_table = sut.servo_table();
  EXPECT_GT(servo_table.servos[0].temperature, 25) << "ID 1 overheats";
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace doppel::gateway
