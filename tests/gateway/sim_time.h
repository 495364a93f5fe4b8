#pragma once
// Waiting on simulation time, not on the wall clock: a Protocol 1.0 IMU's Sample Counter (48, +1
// per 20 ms sample; the FUmanoid IMU, docs/devices.md) counts it, so a test judges a robot after
// the simulated seconds even when a loaded machine runs the simulation behind the wall clock.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <thread>

#include "reference_client.h"

namespace doppel::testing {

inline constexpr double kImuSamplePeriodS = 0.020;

// The IMU's Sample Counter now (0 and a test failure when it does not answer within 1 s).
inline uint16_t imu_sample_counter(SerialClient& client, uint8_t imu_id = 100) {
  const Bytes reply = client.transact(p1_instruction(imu_id, 0x02, {48, 2}), 8, 1000);
  EXPECT_EQ(reply.size(), 8u) << "no Sample Counter from IMU " << int(imu_id);
  return reply.size() == 8u ? static_cast<uint16_t>(reply[5] | (reply[6] << 8)) : uint16_t{0};
}

// Returns once `seconds` of simulation time have passed; fails the test after `give_up_s` of
// wall-clock time (a stalled simulation).
inline void wait_sim_time(SerialClient& client, double seconds, uint8_t imu_id = 100, int give_up_s = 40) {
  const uint16_t start = imu_sample_counter(client, imu_id);
  const auto samples = static_cast<uint16_t>(seconds / kImuSamplePeriodS);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(give_up_s);
  while (static_cast<uint16_t>(imu_sample_counter(client, imu_id) - start) < samples) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the simulation did not advance " << seconds << " s";
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace doppel::testing
