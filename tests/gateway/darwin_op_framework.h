#pragma once
// What the DARwIn-OP framework (darwinop-ens/darwin-op, Framework/, commit fe301d0) sends and reads
// on the darwin-op robot's bus, shared by its integration and physics tests: the IDs, the
// walk-ready pose, the gains Walking sets, MotionManager::Process()'s SYNC WRITE and
// CM730::BulkRead()'s BULK READ.

#include <array>
#include <cmath>
#include <cstdint>

#include "reference_client.h"

namespace doppel::testing::darwin {

inline constexpr uint32_t kBaud = 1000000;
inline constexpr uint8_t kPing = 0x01, kRead = 0x02, kWrite = 0x03, kSyncWrite = 0x83, kBulkRead = 0x92;
inline constexpr uint8_t kBroadcast = 0xFE;
inline constexpr uint8_t kCm730 = 200, kRightFsr = 111, kLeftFsr = 112;
inline constexpr uint8_t kServoCount = 20;  // MX-28, IDs 1..20 (JointData.h)
// CM730.h / MX28.h / FSR.h addresses.
inline constexpr uint8_t kDxlPower = 24, kGyroZ = 38, kAccelX = 44, kVoltage = 50;
inline constexpr uint8_t kDGain = 26, kPGain = 28, kGoalPosition = 30, kPresentPosition = 36, kTorqueEnable = 24;
inline constexpr uint8_t kFsr1 = 26;

// data/robots/darwin-op.textproto: the sum of its body masses (Webots' DARwIn-OP figures).
inline constexpr double kRobotMassKg = 2.9253241;
inline constexpr double kStandardGravity = 9.80665;
// The walk-ready pose leans the trunk forward by the hips' HIP_PITCH_OFFSET as the counts give it:
// -(hip + knee + ankle) = -(-411 + 605 - 341) x 360 / 4096 = 12.92 deg (the robot file's lean).
inline constexpr double kLeanDeg = 12.92;

// Page 9 "walkready" of Data/motion_4096.bin (= Walking's standing pose with its defaults), Goal
// Position of IDs 1..20; index 0 unused.
inline constexpr std::array<uint16_t, kServoCount + 1> kWalkReady = {
    0,           2048 - 550,  2048 + 470,  2048 - 203,  2048 + 200,  2048 + 333, 2048 - 336,
    2048,        2048,        2048 + 4,    2048 - 4,    2048 - 411,  2048 + 411, 2048 + 605,
    2048 - 605,  2048 + 341,  2048 - 341,  2048 + 9,    2048 - 9,    2048,       2048 + 113};

// The P gain MotionManager sends for each ID while Walking owns the body and Head the head:
// Walking.cpp sets 8 on the arms (IDs 1..6) and its P_GAIN on the legs, JointData::P_GAIN_DEFAULT
// = 32 unless config.ini's [Walking] p_gain says otherwise (Walking::LoadINISettings); Head keeps
// the default 32. The walk-ready Action page 9 gives the same (compliance slopes 0x55 -> 32, arms
// 0x77 -> 8). I and D stay 0.
inline constexpr uint8_t kDefaultPGain = 32;
inline constexpr uint8_t p_gain(uint8_t id, uint8_t leg_p = kDefaultPGain) {
  return id <= 6 ? 8 : id >= 19 ? kDefaultPGain : leg_p;
}

// MotionManager::Process(): one SYNC WRITE of D, I, P, a reserved 0 and Goal Position (MX-28
// 26..31, MX28::PARAM_BYTES = 7) for every joint.
inline Bytes framework_sync_write(const std::array<uint16_t, kServoCount + 1>& goal, uint8_t leg_p = kDefaultPGain) {
  Bytes params = {kDGain, 6};
  for (uint8_t id = 1; id <= kServoCount; ++id) {
    params.insert(params.end(), {id, 0, 0, p_gain(id, leg_p), 0, static_cast<uint8_t>(goal[id] & 0xFF),
                                 static_cast<uint8_t>(goal[id] >> 8)});
  }
  return p1_instruction(kBroadcast, kSyncWrite, params);
}

// CM730::BulkRead() as MakeBulkReadPacket() builds it: 30 bytes from 24 of the CM-730, then 10
// bytes from 26 (FSR1..4, X, Y) of the left and of the right foot board.
inline Bytes framework_bulk_read() {
  return p1_instruction(kBroadcast, kBulkRead, {0x00, 30, kCm730, kDxlPower, 10, kLeftFsr, kFsr1, 10, kRightFsr, kFsr1});
}
inline constexpr std::size_t kBulkReplyBytes = (6 + 30) + 2 * (6 + 10);

inline uint16_t word_at(const Bytes& bytes, std::size_t offset) {
  return static_cast<uint16_t>(bytes.at(offset) | (bytes.at(offset + 1) << 8));
}

// The CM-730's ACC value for a specific force of `g` (in g) along its axis (e-Manual: 512 + 128 per g).
inline int accel_counts(double g) { return static_cast<int>(std::lround(512.0 + 128.0 * g)); }

}  // namespace doppel::testing::darwin
