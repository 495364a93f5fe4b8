#pragma once
// What the standing and held tests of the Protocol 2.0 robots on four buses (fumanoid-x430,
// wolfgang) read as a driver: one reference client per pty, a READ whose status is checked, SYNC
// WRITE, Present Position of every servo, the Bit-Bots IMU's quaternion as roll and pitch, the
// BitFoot boards' load and simulation time from a servo's Realtime Tick. Written once so that the
// two tests read their robots alike.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "doppel_process.h"
#include "reference_client.h"
#include "reference_client_p2.h"

namespace doppel::testing {

inline float f32_at(const Bytes& b, std::size_t offset) {
  uint32_t raw = 0;
  for (int i = 0; i < 4; ++i) raw |= static_cast<uint32_t>(b.at(offset + static_cast<std::size_t>(i))) << (8 * i);
  float f;
  std::memcpy(&f, &raw, sizeof f);
  return f;
}

// The parameters of a Protocol 2.0 READ (or the head of a SYNC READ / SYNC WRITE): address, length.
inline Bytes p2_read_params(uint16_t address, uint16_t length) {
  Bytes p = le16(address);
  const Bytes l = le16(length);
  p.insert(p.end(), l.begin(), l.end());
  return p;
}

struct RollPitch {
  double roll_deg = 0.0;
  double pitch_deg = 0.0;
};

// Roll and pitch of the ZYX (yaw, pitch, roll) rotation the quaternion x y z w describes.
inline RollPitch roll_pitch_deg(double x, double y, double z, double w) {
  return {std::atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y)) * 180.0 / M_PI,
          std::asin(std::clamp(2.0 * (w * y - z * x), -1.0, 1.0)) * 180.0 / M_PI};
}

class P2RobotBuses {
 public:
  // Bit-Bots IMU (docs/devices.md §8.2): quaternion x y z w as float32 from 60. BitFoot (P7): four
  // int32 counts from 36, default calibration 1e7 counts + force / 3e-6 N per count.
  static constexpr uint16_t kImuQuaternion = 60, kFootSensors = 36;
  static constexpr uint16_t kPresentPosition = 132, kRealtimeTick = 120;  // X series and MX(2.0)
  static constexpr double kFootZeroCounts = 1e7, kFootNewtonPerCount = 3e-6;

  // Clients on ttyDXL0..; `servos[b]` lists the servo IDs of bus b in the order positions are read.
  P2RobotBuses(DoppelProcess& doppel, uint32_t baud, std::vector<std::vector<uint8_t>> servos)
      : servos_(std::move(servos)) {
    for (std::size_t b = 0; b < servos_.size(); ++b) {
      clients_.push_back(std::make_unique<SerialClient>(doppel.link("ttyDXL" + std::to_string(b)), baud));
    }
  }

  SerialClient& bus(int b) { return *clients_.at(static_cast<std::size_t>(b)); }

  // One READ; the status' parameters (empty, and a test failure, on any transport or status error).
  Bytes read(int b, uint8_t id, uint16_t address, uint16_t length) {
    const auto statuses =
        parse_p2_statuses(transact_p2(bus(b), p2_instruction(id, 0x02, p2_read_params(address, length)), 1));
    if (!statuses || statuses->size() != 1 || (*statuses)[0].id != id || (*statuses)[0].error != 0 ||
        (*statuses)[0].params.size() != length) {
      ADD_FAILURE() << "no " << length << "-byte READ reply from ID " << int(id) << " on bus " << b;
      return {};
    }
    return (*statuses)[0].params;
  }

  // SYNC WRITE of one `size`-byte value per servo of bus `b`: value(id).
  template <class Value>
  void sync_write(int b, uint16_t address, uint16_t size, Value value) {
    Bytes params = p2_read_params(address, size);
    for (uint8_t id : servos_.at(static_cast<std::size_t>(b))) {
      params.push_back(id);
      const auto v = static_cast<uint32_t>(value(id));
      for (uint16_t i = 0; i < size; ++i) params.push_back(static_cast<uint8_t>(v >> (8 * i)));
    }
    bus(b).send(p2_instruction(0xFE, 0x83, params));
  }

  // The four cells of a BitFoot board, in newtons.
  double foot_total_n(int b, uint8_t id) {
    const Bytes raw = read(b, id, kFootSensors, 16);
    double total = 0.0;
    for (std::size_t cell = 0; cell < 4 && raw.size() == 16; ++cell) {
      total += (static_cast<double>(le32_at(raw, 4 * cell)) - kFootZeroCounts) * kFootNewtonPerCount;
    }
    return total;
  }

  // The Bit-Bots IMU's attitude (zero, and a test failure, when it does not answer).
  RollPitch imu_roll_pitch(int b, uint8_t id) {
    const Bytes q = read(b, id, kImuQuaternion, 16);
    if (q.size() != 16) return {};
    return roll_pitch_deg(f32_at(q, 0), f32_at(q, 4), f32_at(q, 8), f32_at(q, 12));
  }

  // Present Position of every servo, bus by bus in `servos` order (-1 where a READ failed).
  std::vector<int32_t> read_positions() {
    std::vector<int32_t> positions;
    for (std::size_t b = 0; b < servos_.size(); ++b) {
      for (uint8_t id : servos_[b]) {
        const Bytes raw = read(static_cast<int>(b), id, kPresentPosition, 4);
        positions.push_back(raw.size() == 4 ? le32_at(raw, 0) : -1);
      }
    }
    return positions;
  }

  // Returns once `seconds` of simulation time have passed, read from servo `id`'s Realtime Tick
  // (ms of simulation time, wraps at 32768) on bus `b`: on a loaded machine the simulation may run
  // behind the wall clock. Fails the test after `give_up_s` of wall-clock time.
  void wait_sim_time(double seconds, int b, uint8_t id, int give_up_s) {
    auto tick_ms = [&] {
      const Bytes tick = read(b, id, kRealtimeTick, 2);
      return tick.size() == 2 ? static_cast<int>(tick[0] | (tick[1] << 8)) : 0;
    };
    const int start = tick_ms();
    const auto wanted = static_cast<int>(seconds * 1000.0);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(give_up_s);
    while ((tick_ms() - start + 32768) % 32768 < wanted) {
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the simulation did not advance " << seconds << " s";
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }

 private:
  std::vector<std::vector<uint8_t>> servos_;
  std::vector<std::unique_ptr<SerialClient>> clients_;
};

}  // namespace doppel::testing
