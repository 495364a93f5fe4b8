#include "dynamixel/opencr_board.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "dynamixel/protocol2.h"

namespace doppel::dynamixel {

namespace {

constexpr uint8_t kMaxId = 252;

// The firmware's RW attribute (dxl_node_op3_reset): ID, baud, delay, status level, the offsets, the
// outputs at 24..29 and IMU Control.
bool writable(uint16_t address) noexcept {
  return (address >= opencr::kId && address <= opencr::kReturnDelayTime) || address == opencr::kStatusReturnLevel ||
         (address >= opencr::kRollOffset && address < opencr::kButton) || address == opencr::kImuControl;
}

uint16_t le16(const uint8_t* p) noexcept { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

int32_t saturated_i16(double value) noexcept {
  if (!std::isfinite(value)) {
    return 0;
  }
  return static_cast<int32_t>(std::lround(std::clamp(value, -32768.0, 32767.0)));
}

// (int16_t)(deg * 10.) of the firmware: truncation toward zero.
int32_t tenths(double deg) noexcept {
  if (!std::isfinite(deg)) {
    return 0;
  }
  return static_cast<int32_t>(std::clamp(deg * 10.0, -32768.0, 32767.0));
}

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

}  // namespace

OpenCr::OpenCr(uint8_t id, uint8_t baud_raw) : spec_(p2_board_spec(P2DeviceKind::kOpenCr)) {
  if (id > kMaxId) {
    throw std::invalid_argument(std::string(spec_.name) + ": ID " + std::to_string(id) + " is outside 0..252");
  }
  if (p2_baud_bps(baud_raw) == 0) {
    throw std::invalid_argument(std::string(spec_.name) + ": baud index " + std::to_string(baud_raw) +
                                " is outside 0..7");
  }
  // Power-up values: EEPROM defaults, RAM 0 except LED RGB = 0x001F (dxl_node_op3_init).
  for (const P2RegisterSpec& r : spec_.registers) {
    for (uint8_t b = 0; b < r.size; ++b) {
      table_[r.address + b] = static_cast<uint8_t>(static_cast<uint32_t>(r.default_raw) >> (8 * b));
    }
  }
  table_[opencr::kId] = id;
  table_[opencr::kBaudRate] = baud_raw;
  active_id_ = id;
  apply(ImuFeedback{});
  apply(PowerFeedback{});
}

uint32_t OpenCr::baud_bps() const noexcept { return p2_baud_bps(table_[opencr::kBaudRate]); }

void OpenCr::store_i16(uint16_t address, int32_t value) noexcept {
  const auto raw = static_cast<uint16_t>(static_cast<int16_t>(value));
  table_[address] = static_cast<uint8_t>(raw & 0xFF);
  table_[address + 1] = static_cast<uint8_t>(raw >> 8);
}

int16_t OpenCr::load_i16(uint16_t address) const noexcept { return static_cast<int16_t>(le16(&table_[address])); }

void OpenCr::write_bytes(uint16_t start, const uint8_t* data, std::size_t n) noexcept {
  for (std::size_t i = 0; i < n && start + i < opencr::kTableBytes; ++i) {
    if (writable(static_cast<uint16_t>(start + i))) {
      table_[start + i] = data[i];
    }
  }
  // Offsets written by the host take effect for roll and pitch as at power-up (dxl_node_op3_reset).
  offset_deg_[0] = load_i16(opencr::kRollOffset) / 10.0;
  offset_deg_[1] = load_i16(opencr::kPitchOffset) / 10.0;
}

void OpenCr::chain_reply(uint16_t position, uint16_t start, uint16_t length, Response& response) noexcept {
  std::copy_n(table_.begin() + start, length, scratch_.begin());
  response.transmits = encode_protocol2_status(active_id_, 0, scratch_.data(), length, response.status);
  response.timing = position == 0 ? ReplyTiming::kAfterInstruction : ReplyTiming::kAfterPrevious;
  response.chain_position = position;
}

void OpenCr::handle(const InstructionPacket& packet, Response& response) noexcept {
  response.transmits = false;
  response.timing = ReplyTiming::kAfterInstruction;
  response.chain_position = 0;
  const bool broadcast = packet.id == kBroadcastId;
  if (packet.protocol != Protocol::kV2 || !packet.checksum_ok || (packet.id != active_id_ && !broadcast)) {
    return;
  }
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  const auto reply = [&](uint8_t error, const uint8_t* data, std::size_t size) {
    response.transmits = encode_protocol2_status(active_id_, error, data, size, response.status);
  };
  switch (packet.instruction) {
    case instruction::kPing: {
      const uint8_t data[3] = {table_[0], table_[1], table_[opencr::kFirmwareVersion]};
      reply(0, data, sizeof data);
      if (broadcast) {
        response.timing = ReplyTiming::kIdOrder;
      }
      return;
    }
    case instruction::kRead: {
      if (broadcast || n != 4) {
        return;
      }
      const uint16_t start = le16(p);
      const uint16_t length = le16(p + 2);
      if (start >= opencr::kTableBytes || length > scratch_.size() || start + length > table_.size()) {
        reply(p2_error::kDataLength, nullptr, 0);
        return;
      }
      std::copy_n(table_.begin() + start, length, scratch_.begin());
      reply(0, scratch_.data(), length);
      return;
    }
    case instruction::kWrite: {
      if (broadcast) {
        return;
      }
      if (n <= 2 || le16(p) >= opencr::kTableBytes) {
        reply(p2_error::kDataLength, nullptr, 0);
        return;
      }
      reply(0, nullptr, 0);  // acknowledged before it runs
      write_bytes(le16(p), p + 2, n - 2);
      return;
    }
    case instruction::kSyncRead: {
      if (!broadcast || n < 5 || n - 4 > 255) {
        return;
      }
      const uint16_t start = le16(p);
      const uint16_t length = le16(p + 2);
      if (start + length > opencr::kTableBytes) {
        return;
      }
      for (std::size_t i = 4; i < n; ++i) {
        if (p[i] == active_id_) {
          chain_reply(static_cast<uint16_t>(i - 4), start, length, response);
          return;
        }
      }
      return;
    }
    case instruction::kSyncWrite: {
      if (!broadcast || n < 4) {
        return;
      }
      const uint16_t start = le16(p);
      const uint16_t length = le16(p + 2);
      if (n < 4u + length + 1u || start + length > opencr::kTableBytes) {
        return;
      }
      for (std::size_t i = 4; i + length + 1 <= n; i += length + 1u) {
        if (p[i] == active_id_) {
          write_bytes(start, p + i + 1, length);
          return;
        }
      }
      return;
    }
    case instruction::kBulkRead: {
      if (!broadcast || n < 5 || n % 5 != 0) {
        return;
      }
      for (std::size_t i = 0; i < n; i += 5) {
        if (p[i] == active_id_) {
          const uint16_t start = le16(p + i + 1);
          const uint16_t length = le16(p + i + 3);
          if (start + length <= opencr::kTableBytes) {
            chain_reply(static_cast<uint16_t>(i / 5), start, length, response);
          }
          return;
        }
      }
      return;
    }
    case instruction::kBulkWrite: {
      if (!broadcast) {
        return;
      }
      for (std::size_t i = 0; i + 5 <= n;) {
        const uint16_t start = le16(p + i + 1);
        const uint16_t length = le16(p + i + 3);
        if (n < i + 5 + length) {
          return;
        }
        if (p[i] == active_id_) {
          write_bytes(start, p + i + 5, length);
          return;
        }
        i += 5u + length;
      }
      return;
    }
    default:
      return;  // no handler registered in the firmware: dropped
  }
}

void OpenCr::apply(const ImuFeedback& feedback) noexcept {
  const double g = 1.0 / kStandardGravityMS2;
  store_i16(opencr::kGyroX, saturated_i16(feedback.w_WS_S_rad_s[0] * kRadToDeg * kGyroCountsPerDegS));
  store_i16(opencr::kGyroY, saturated_i16(feedback.w_WS_S_rad_s[1] * kRadToDeg * kGyroCountsPerDegS));
  store_i16(opencr::kGyroZ, saturated_i16(feedback.w_WS_S_rad_s[2] * kRadToDeg * kGyroCountsPerDegS));
  store_i16(opencr::kAccX, saturated_i16(feedback.a_WS_S_m_s2[0] * g * kAccCountsPerG));
  store_i16(opencr::kAccY, saturated_i16(feedback.a_WS_S_m_s2[1] * g * kAccCountsPerG));
  store_i16(opencr::kAccZ, saturated_i16(feedback.a_WS_S_m_s2[2] * g * kAccCountsPerG));
  angle_deg_ = {feedback.roll_rad * kRadToDeg, feedback.pitch_rad * kRadToDeg, feedback.yaw_rad * kRadToDeg};
  // IMU Control bits 0..2: the current angle becomes the offset (the firmware averages 512 samples
  // first), stored at 18/20/22, and the bit clears; bit 3 (gyro calibration) clears at once.
  uint8_t& control = table_[opencr::kImuControl];
  for (int axis = 0; axis < 3; ++axis) {
    if ((control & (1u << axis)) != 0 && std::isfinite(angle_deg_[axis])) {
      offset_deg_[axis] = angle_deg_[axis];
      store_i16(static_cast<uint16_t>(opencr::kRollOffset + 2 * axis), tenths(offset_deg_[axis]));
      control = static_cast<uint8_t>(control & ~(1u << axis));
    }
  }
  control = static_cast<uint8_t>(control & ~(1u << 3));
  store_i16(opencr::kRoll, tenths(angle_deg_[0] - offset_deg_[0]));
  store_i16(opencr::kPitch, tenths(angle_deg_[1] - offset_deg_[1]));
  store_i16(opencr::kYaw, tenths(angle_deg_[2] - offset_deg_[2]));
}

void OpenCr::apply(const PowerFeedback& feedback) noexcept {
  const double raw = (feedback.supply_v + 0.5) * 10.0;
  table_[opencr::kVoltage] = std::isfinite(raw) ? static_cast<uint8_t>(std::clamp(raw, 0.0, 255.0)) : 0;
}

void OpenCr::apply(const ButtonInput& input) noexcept { table_[opencr::kButton] = input.pressed & 0x0F; }

}  // namespace doppel::dynamixel
