// The fault model (faults/fault.h) and what each fault does (faults/effects.h), without a bus:
// the checks name their fields, the random streams repeat with their seed, each fault changes
// only what it should and only while it is in force.
#include <gtest/gtest.h>

#include <cmath>
#include <set>
#include <vector>

#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"
#include "faults/effects.h"
#include "faults/fault.h"

namespace doppel::faults {
namespace {

constexpr int64_t kSecond = 1'000'000'000;

Fault fault(uint32_t number, FaultKind kind, int32_t bus, int32_t id, double value = 0.0, double rate = 0.0,
            int64_t start_ns = 0, int64_t end_ns = INT64_MAX) {
  Fault f;
  f.number = number;
  f.spec.kind = kind;
  f.spec.bus = bus;
  f.spec.id = id;
  f.spec.value = value;
  f.spec.rate = rate;
  f.start_ns = start_ns;
  f.end_ns = end_ns;
  return f;
}

FaultTable table_of(std::initializer_list<Fault> faults) {
  FaultTable table;
  for (const Fault& f : faults) table.faults[table.count++] = f;
  return table;
}

TEST(FaultModel, EveryKindHasAUniqueNameAndIsFoundByIt) {
  std::set<std::string_view> names;
  for (const FaultKindInfo& k : fault_kinds()) {
    EXPECT_TRUE(names.insert(k.name).second) << k.name;
    ASSERT_TRUE(fault_kind(k.name).has_value()) << k.name;
    EXPECT_EQ(*fault_kind(k.name), k.kind);
    EXPECT_EQ(&info(k.kind), &k) << "the table is in enum order";
  }
  EXPECT_FALSE(fault_kind("melt").has_value());
}

TEST(FaultModel, TheCheckNamesTheMissingOrWrongField) {
  FaultSpec spec;
  spec.kind = FaultKind::kOverheat;
  spec.value = 5.0;
  EXPECT_NE(check(spec).find("'bus'"), std::string::npos);
  spec.bus = 0;
  EXPECT_NE(check(spec).find("'id'"), std::string::npos);
  spec.id = 14;
  EXPECT_EQ(check(spec), "");
  spec.value = 0.0;
  EXPECT_NE(check(spec).find("'rise_c_per_s'"), std::string::npos);
  spec.value = NAN;
  EXPECT_NE(check(spec).find("'rise_c_per_s'"), std::string::npos);
  spec.value = 5.0;
  spec.duration_ns = -1;
  EXPECT_NE(check(spec).find("'duration_s'"), std::string::npos);

  FaultSpec drop;
  drop.kind = FaultKind::kDrop;
  drop.bus = 1;
  EXPECT_NE(check(drop).find("'rate'"), std::string::npos);
  drop.rate = 1.0;
  EXPECT_EQ(check(drop), "");
  drop.id = 3;
  EXPECT_NE(check(drop).find("'id'"), std::string::npos);

  FaultSpec brownout;
  brownout.kind = FaultKind::kBrownout;
  brownout.value = 9.0;
  EXPECT_EQ(check(brownout), "");
  brownout.bus = 0;
  EXPECT_NE(check(brownout).find("'bus'"), std::string::npos);
}

TEST(FaultModel, TheRandomStreamRepeatsWithItsSeedAndDiffersWithAnother) {
  std::vector<double> a, b, c;
  for (uint64_t n = 0; n < 1000; ++n) {
    a.push_back(uniform(42, n));
    b.push_back(uniform(42, n));
    c.push_back(uniform(43, n));
  }
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  // Uniform on [0, 1): the mean of 1000 draws within 4 standard errors (1/sqrt(12 * 1000) = 0.0091).
  double mean = 0.0;
  for (double x : a) {
    EXPECT_GE(x, 0.0);
    EXPECT_LT(x, 1.0);
    mean += x / 1000.0;
  }
  EXPECT_NEAR(mean, 0.5, 4 * 0.0091);
  // Gaussian: mean 0 and variance 1 within 4 standard errors for 4000 draws.
  double sum = 0.0, squares = 0.0;
  for (uint64_t n = 0; n < 4000; ++n) {
    const double g = gaussian(7, n);
    sum += g;
    squares += g * g;
  }
  EXPECT_NEAR(sum / 4000.0, 0.0, 4.0 / std::sqrt(4000.0));
  EXPECT_NEAR(squares / 4000.0, 1.0, 4.0 * std::sqrt(2.0 / 4000.0));
}

TEST(FaultEffects, OverheatRampsTheTemperatureFromItsStartAndOnlyOnItsServo) {
  const FaultTable table = table_of({fault(1, FaultKind::kOverheat, 0, 14, 5.0, 0.0, 2 * kSecond, 12 * kSecond)});
  StuckHold hold;
  dynamixel::ServoFeedback at_start, later, other, after;
  apply_servo(table, 0, 14, 2 * kSecond, at_start, hold);
  EXPECT_DOUBLE_EQ(at_start.temperature_c, 25.0);
  apply_servo(table, 0, 14, 6 * kSecond, later, hold);
  EXPECT_DOUBLE_EQ(later.temperature_c, 25.0 + 5.0 * 4.0);
  apply_servo(table, 0, 15, 6 * kSecond, other, hold);
  EXPECT_DOUBLE_EQ(other.temperature_c, 25.0);
  apply_servo(table, 1, 14, 6 * kSecond, other, hold);
  EXPECT_DOUBLE_EQ(other.temperature_c, 25.0) << "the same ID on another bus";
  apply_servo(table, 0, 14, 12 * kSecond, after, hold);
  EXPECT_DOUBLE_EQ(after.temperature_c, 25.0) << "ended";
}

TEST(FaultEffects, VoltageOverloadAndBrownOutChangeWhatTheServoMeasures) {
  StuckHold hold;
  dynamixel::ServoFeedback feedback;
  apply_servo(table_of({fault(1, FaultKind::kVoltage, 0, 3, 5.5), fault(2, FaultKind::kOverload, 0, 3)}), 0, 3, 0,
              feedback, hold);
  EXPECT_DOUBLE_EQ(feedback.voltage_v, 5.5);
  EXPECT_TRUE(feedback.overload);
  dynamixel::ServoFeedback sagged;
  sagged.voltage_v = 14.8;
  apply_servo(table_of({fault(1, FaultKind::kBrownout, -1, -1, 9.0)}), 2, 7, 0, sagged, hold);
  EXPECT_DOUBLE_EQ(sagged.voltage_v, 9.0) << "every servo of the robot";
  dynamixel::PowerFeedback power;
  apply_power(table_of({fault(1, FaultKind::kBrownout, -1, -1, 9.0)}), 0, power);
  EXPECT_DOUBLE_EQ(power.supply_v, 9.0);
}

TEST(FaultEffects, AStuckPositionHoldsWhereItWasCaughtAndNoiseIsAFunctionOfTheTime) {
  const FaultTable stuck = table_of({fault(4, FaultKind::kStuck, 0, 1)});
  StuckHold hold;
  dynamixel::ServoFeedback f;
  f.position_rad = 0.3;
  f.velocity_rad_s = 1.0;
  apply_servo(stuck, 0, 1, 0, f, hold);
  EXPECT_DOUBLE_EQ(f.position_rad, 0.3);
  dynamixel::ServoFeedback moved;
  moved.position_rad = 0.8;
  moved.velocity_rad_s = 1.0;
  apply_servo(stuck, 0, 1, kSecond, moved, hold);
  EXPECT_DOUBLE_EQ(moved.position_rad, 0.3);
  EXPECT_DOUBLE_EQ(moved.velocity_rad_s, 0.0);
  dynamixel::ServoFeedback free;
  free.position_rad = 0.8;
  apply_servo(FaultTable{}, 0, 1, kSecond, free, hold);
  EXPECT_DOUBLE_EQ(free.position_rad, 0.8);
  EXPECT_EQ(hold.number, 0u);

  const FaultTable noisy = table_of({fault(5, FaultKind::kPositionNoise, 0, 1, 0.01)});
  std::vector<double> first, again;
  for (int64_t ms = 0; ms < 200; ++ms) {
    dynamixel::ServoFeedback a, b;
    apply_servo(noisy, 0, 1, ms * 1'000'000, a, hold);
    apply_servo(noisy, 0, 1, ms * 1'000'000 + 500'000, b, hold);  // within the same millisecond
    first.push_back(a.position_rad);
    again.push_back(b.position_rad);
  }
  EXPECT_EQ(first, again);
  double squares = 0.0;
  for (double x : first) squares += x * x;
  EXPECT_NEAR(std::sqrt(squares / 200.0), 0.01, 0.003) << "sigma 0.01 rad (200 draws: standard error 5 %)";
}

TEST(FaultEffects, TorqueScaleOfAWeakMotorAndASaggingSupply) {
  EXPECT_DOUBLE_EQ(torque_scale(FaultTable{}, 0, 15, 0, 14.8), 1.0);
  EXPECT_DOUBLE_EQ(torque_scale(table_of({fault(1, FaultKind::kWeak, 0, 15, 0.25)}), 0, 15, 0, 14.8), 0.25);
  EXPECT_DOUBLE_EQ(torque_scale(table_of({fault(1, FaultKind::kWeak, 0, 15, 0.25)}), 0, 16, 0, 14.8), 1.0);
  EXPECT_DOUBLE_EQ(torque_scale(table_of({fault(1, FaultKind::kBrownout, -1, -1, 7.4)}), 0, 16, 0, 14.8), 0.5)
      << "a DC motor's stall torque is proportional to its voltage";
}

TEST(FaultEffects, DeadServosAndASilentBusAreUnreachable) {
  const FaultTable dead = table_of({fault(1, FaultKind::kDead, 0, 17, 0, 0, kSecond, 2 * kSecond)});
  EXPECT_FALSE(unreachable(dead, 0, 17, 0));
  EXPECT_TRUE(unreachable(dead, 0, 17, kSecond));
  EXPECT_FALSE(unreachable(dead, 0, 16, kSecond));
  EXPECT_FALSE(unreachable(dead, 0, 17, 2 * kSecond));
  const FaultTable silent = table_of({fault(1, FaultKind::kSilent, 1, -1)});
  EXPECT_TRUE(unreachable(silent, 1, 5, 0));
  EXPECT_FALSE(unreachable(silent, 0, 5, 0));
}

TEST(FaultEffects, AFaultActsFromAnySlotBelowTheCount) {
  // The gateway keeps a fault in its slot while others are cleared around it: slot 2 of 3 in use.
  FaultTable table;
  table.faults[2] = fault(3, FaultKind::kSilent, 0, -1);
  table.count = 3;
  EXPECT_EQ(in_use(table).size(), 3u);
  EXPECT_TRUE(unreachable(table, 0, 5, 0));
  EXPECT_TRUE(in_use(FaultTable{}).empty());
}

TEST(FaultEffects, SensorDropoutFreezesAndBiasShifts) {
  dynamixel::ImuFeedback imu;
  EXPECT_FALSE(apply_imu(table_of({fault(1, FaultKind::kImuDropout, -1, -1)}), 0, 100, 0, imu));
  EXPECT_TRUE(apply_imu(table_of({fault(1, FaultKind::kImuDropout, 0, 99)}), 0, 100, 0, imu)) << "another board";
  EXPECT_TRUE(apply_imu(table_of({fault(1, FaultKind::kImuBias, 0, 100, 0.05)}), 0, 100, 0, imu));
  for (double w : imu.w_WS_S_rad_s) EXPECT_DOUBLE_EQ(w, 0.05);
  dynamixel::FootFeedback foot;
  foot.force_n = {1.0, 2.0, 3.0, 4.0};
  EXPECT_TRUE(apply_foot(table_of({fault(1, FaultKind::kFootBias, -1, -1, 10.0)}), 0, 101, 0, foot));
  EXPECT_EQ(foot.force_n, (std::array<double, 4>{11.0, 12.0, 13.0, 14.0}));
  EXPECT_FALSE(apply_foot(table_of({fault(1, FaultKind::kFootDropout, 0, 101)}), 0, 101, 0, foot));
}

// A PING status of ID 5 (P1: FF FF 05 02 00 F8, reference §1.1).
dynamixel::StatusPacket ping_status(uint8_t id) {
  dynamixel::StatusPacket p;
  dynamixel::encode_protocol1_status(id, 0, nullptr, 0, p);
  return p;
}

TEST(WireFaultsTest, CorruptionBreaksTheChecksumAndRepeatsWithTheSeed) {
  const dynamixel::StatusPacket status = ping_status(5);
  ASSERT_EQ(status.size, 6);
  const dynamixel::OutgoingStatus out{&status, 5, 0, false, false, 0, false};
  dynamixel::InstructionPacket ping;
  ping.id = 5;
  ping.instruction = dynamixel::instruction::kPing;
  Fault corrupt = fault(3, FaultKind::kCorrupt, 0, -1, 0.0, 0.5);
  corrupt.spec.seed = 99;
  const FaultTable table = table_of({corrupt});
  auto pattern = [&](WireFaults& wire) {
    std::vector<bool> bad;
    for (int i = 0; i < 200; ++i) {
      const auto result = wire.apply(table, 0, 0, ping, {&out, 1});
      EXPECT_EQ(result.size(), 1u);
      const dynamixel::StatusPacket& p = *result[0].packet;
      const bool changed = !std::equal(p.bytes.begin(), p.bytes.begin() + p.size, status.bytes.begin());
      if (changed) {
        EXPECT_NE(dynamixel::protocol1_checksum(p.bytes.data() + 2, p.size - 3), p.bytes[p.size - 1])
            << "a flipped byte breaks the checksum";
        EXPECT_EQ(p.bytes[0], 0xFF);
        EXPECT_EQ(p.bytes[1], 0xFF);
      }
      bad.push_back(changed);
    }
    return bad;
  };
  WireFaults first, second;
  const std::vector<bool> a = pattern(first), b = pattern(second);
  EXPECT_EQ(a, b) << "the same traffic meets the same corruption";
  const auto corrupted = std::count(a.begin(), a.end(), true);
  EXPECT_GT(corrupted, 60);  // binomial(200, 0.5): 100 +- 7; these bounds are 5.7 sigma away
  EXPECT_LT(corrupted, 140);
  EXPECT_EQ(first.counters().corrupted, static_cast<uint64_t>(corrupted));
}

TEST(WireFaultsTest, DropLateAndAStrayStatus) {
  const dynamixel::StatusPacket status = ping_status(5);
  const dynamixel::OutgoingStatus out{&status, 5, 0, false, false, 0, false};
  dynamixel::InstructionPacket ping;
  ping.id = 5;
  ping.instruction = dynamixel::instruction::kPing;
  WireFaults wire;
  EXPECT_TRUE(wire.apply(table_of({fault(1, FaultKind::kDrop, 0, -1, 0.0, 1.0)}), 0, 0, ping, {&out, 1}).empty());
  EXPECT_EQ(wire.apply(table_of({fault(1, FaultKind::kDrop, 0, -1, 0.0, 1.0)}), 1, 0, ping, {&out, 1}).size(), 1u)
      << "another bus";

  const auto late = wire.apply(table_of({fault(2, FaultKind::kLate, 0, 5, 2500.0)}), 0, 0, ping, {&out, 1});
  ASSERT_EQ(late.size(), 1u);
  EXPECT_EQ(late[0].extra_delay_ns, 2'500'000);

  // A stray ID 9 answers with the real answer: the wire carries the AND of both packets.
  const dynamixel::StatusPacket stray = ping_status(9);
  const auto collided = wire.apply(table_of({fault(3, FaultKind::kCollision, 0, 9, 0.0, 1.0)}), 0, 0, ping, {&out, 1});
  ASSERT_EQ(collided.size(), 1u);
  EXPECT_TRUE(collided[0].collision);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(collided[0].packet->bytes[i], status.bytes[i] & stray.bytes[i]);
  // After a broadcast nobody answers: the stray status goes out alone.
  dynamixel::InstructionPacket sync_write;
  sync_write.id = dynamixel::kBroadcastId;
  sync_write.instruction = dynamixel::instruction::kSyncWrite;
  const auto alone = wire.apply(table_of({fault(3, FaultKind::kCollision, 0, 9, 0.0, 1.0)}), 0, 0, sync_write, {});
  ASSERT_EQ(alone.size(), 1u);
  EXPECT_EQ(std::vector<uint8_t>(alone[0].packet->bytes.begin(), alone[0].packet->bytes.begin() + alone[0].packet->size),
            (std::vector<uint8_t>{0xFF, 0xFF, 0x09, 0x02, 0x00, 0xF4}));
}

}  // namespace
}  // namespace doppel::faults
