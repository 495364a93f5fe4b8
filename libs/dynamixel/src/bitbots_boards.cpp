#include "dynamixel/bitbots_boards.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <string>

#include "dynamixel/protocol2.h"

namespace doppel::dynamixel {

namespace {

using Item = BitbotsBoard::Item;

constexpr uint8_t kMaxId = 252;
constexpr uint8_t kFirmwareVersion = 1;
constexpr uint8_t kProtocol2 = 2;

// Items shared by every board (reference §8.1); the model number and firmware are read-only.
#define DOPPEL_BITBOTS_HEADER                                                                            \
  Item{bitbots::kModelNumber, 2, false}, Item{bitbots::kFirmwareVersion, 1, false}, Item{bitbots::kId, 1, true}, \
      Item{bitbots::kBaud, 1, true}, Item{bitbots::kProtocolVersion, 1, true}
#define DOPPEL_BITBOTS_LEDS                                                                                         \
  Item{10, 1, true}, Item{11, 1, true}, Item{12, 1, true}, Item{14, 1, true}, Item{15, 1, true}, Item{16, 1, true}, \
      Item{18, 1, true}, Item{19, 1, true}, Item{20, 1, true}

// Current (BMI088) IMU firmware (reference §8.2): the old firmware's calibration items are unregistered.
constexpr Item kImuItems[] = {
    DOPPEL_BITBOTS_HEADER,        DOPPEL_BITBOTS_LEDS,
    Item{bitbots::kGyroX, 4},     Item{bitbots::kGyroY, 4},       Item{bitbots::kGyroZ, 4},
    Item{bitbots::kAccelX, 4},    Item{bitbots::kAccelY, 4},      Item{bitbots::kAccelZ, 4},
    Item{bitbots::kQuaternionX, 4}, Item{bitbots::kQuaternionY, 4}, Item{bitbots::kQuaternionZ, 4},
    Item{bitbots::kQuaternionW, 4}, Item{76, 1},                  Item{77, 1},
    Item{78, 1},                  Item{bitbots::kGyroOdr, 1, true}, Item{bitbots::kAccelOdr, 1, true},
    Item{bitbots::kGyroRange, 1, true}, Item{bitbots::kAccelRange, 1, true}, Item{bitbots::kDoAdaptiveGain, 1, true},
    Item{bitbots::kDoBiasEstimation, 1, true}, Item{bitbots::kAccelGain, 4, true}, Item{bitbots::kBiasAlpha, 4, true},
};

constexpr Item kFootItems[] = {
    DOPPEL_BITBOTS_HEADER,
    Item{bitbots::kSensor0, 4},
    Item{bitbots::kSensor1, 4},
    Item{bitbots::kSensor2, 4},
    Item{bitbots::kSensor3, 4},
};

constexpr Item kCoreItems[] = {
    DOPPEL_BITBOTS_HEADER,          DOPPEL_BITBOTS_LEDS,     Item{bitbots::kCoreLed, 1, true},
    Item{bitbots::kPower, 1, true}, Item{bitbots::kVext, 2}, Item{bitbots::kVcc, 2},
    Item{bitbots::kVdxl, 2},        Item{bitbots::kCurrent, 2}, Item{bitbots::kPowerSense, 2},
    Item{38, 2},                    Item{40, 2},             Item{42, 2},
    Item{44, 2},                    Item{46, 2},             Item{48, 2},
};

#undef DOPPEL_BITBOTS_HEADER
#undef DOPPEL_BITBOTS_LEDS

uint16_t le16(const uint8_t* p) noexcept { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

uint16_t adc(double volts_per_count, double value) noexcept {
  const double raw = value / volts_per_count;
  if (!std::isfinite(raw)) {
    return 0;
  }
  return static_cast<uint16_t>(std::clamp(std::lround(raw), 0L, 1023L));
}

}  // namespace

BitbotsBoard::BitbotsBoard(const P2ModelSpec& spec, std::span<const Item> items, uint8_t id, uint8_t baud_raw)
    : spec_(spec), items_(items) {
  if (id > kMaxId) {
    throw std::invalid_argument(std::string(spec.name) + ": ID " + std::to_string(id) + " is outside 0..252");
  }
  if (p2_baud_bps(baud_raw, spec.baud7_is_5m) == 0) {
    throw std::invalid_argument(std::string(spec.name) + ": baud index " + std::to_string(baud_raw) + " is outside 0..7");
  }
  store_u16(bitbots::kModelNumber, spec.model_number);
  table_[bitbots::kFirmwareVersion] = kFirmwareVersion;
  table_[bitbots::kId] = id;
  table_[bitbots::kBaud] = baud_raw;
  table_[bitbots::kProtocolVersion] = kProtocol2;
}

uint32_t BitbotsBoard::baud_bps() const noexcept { return p2_baud_bps(table_[bitbots::kBaud], spec_.baud7_is_5m); }

void BitbotsBoard::store_u16(uint16_t address, uint16_t value) noexcept {
  table_[address] = static_cast<uint8_t>(value & 0xFF);
  table_[address + 1] = static_cast<uint8_t>(value >> 8);
}

void BitbotsBoard::store_u32(uint16_t address, uint32_t value) noexcept {
  for (int b = 0; b < 4; ++b) {
    table_[address + b] = static_cast<uint8_t>(value >> (8 * b));
  }
}

void BitbotsBoard::store_f32(uint16_t address, float value) noexcept { store_u32(address, std::bit_cast<uint32_t>(value)); }

float BitbotsBoard::load_f32(uint16_t address) const noexcept {
  uint32_t raw = 0;
  for (int b = 0; b < 4; ++b) {
    raw |= static_cast<uint32_t>(table_[address + b]) << (8 * b);
  }
  return std::bit_cast<float>(raw);
}

void BitbotsBoard::handle(const InstructionPacket& packet, Response& response) noexcept {
  response.transmits = false;
  // The slave executes only valid packets for its own ID (no broadcast, no CRC-error status).
  if (packet.protocol != Protocol::kV2 || !packet.checksum_ok || packet.id != id()) {
    return;
  }
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  const uint8_t own_id = id();
  uint8_t error = 0;
  switch (packet.instruction) {
    case instruction::kPing: {
      const uint8_t data[3] = {table_[bitbots::kModelNumber], table_[bitbots::kModelNumber + 1],
                               table_[bitbots::kFirmwareVersion]};
      response.transmits = encode_protocol2_status(own_id, 0, data, sizeof data, response.status);
      break;
    }
    case instruction::kRead: {
      if (n != 4) {
        return;
      }
      const uint32_t start = le16(p);
      const uint32_t length = le16(p + 2);
      if (length > scratch_.size()) {
        return;  // larger than the slave's packet buffer
      }
      std::fill_n(scratch_.begin(), length, 0);
      // Only items lying entirely inside the requested range are copied.
      for (const Item& item : items_) {
        if (item.address >= start && item.address + item.size <= start + length) {
          std::copy_n(table_.begin() + item.address, item.size, scratch_.begin() + (item.address - start));
        }
      }
      response.transmits = encode_protocol2_status(own_id, 0, scratch_.data(), length, response.status);
      break;
    }
    case instruction::kWrite: {
      if (n < 2) {
        return;
      }
      const uint32_t start = le16(p);
      const std::size_t length = n - 2;
      bool restart = false;
      for (const Item& item : items_) {
        if (!item.writable || item.address < start || item.address + item.size > start + length) {
          continue;
        }
        const uint8_t* value = p + 2 + (item.address - start);
        if (item.address == bitbots::kId && value[0] > kMaxId) {
          error = p2_error::kDataRange;  // the ID is kept
          continue;
        }
        if (item.address == bitbots::kBaud) {
          if (p2_baud_bps(value[0], spec_.baud7_is_5m) == 0) {
            error = p2_error::kDataRange;
            continue;
          }
          restart = true;
        }
        std::copy_n(value, item.size, table_.begin() + item.address);
      }
      if (restart) {
        ++restarts_;
        return;  // the firmware restarts the chip inside the write handler: no status
      }
      response.transmits = encode_protocol2_status(own_id, error, nullptr, 0, response.status);
      break;
    }
    default:
      return;  // parsed and dropped
  }
  response.timing = ReplyTiming::kAfterInstruction;
  response.chain_position = 0;
}

BitbotsImu::BitbotsImu(uint8_t id, uint8_t baud_raw) : BitbotsBoard(p2_board_spec(P2DeviceKind::kBitbotsImu), kImuItems, id, baud_raw) {
  store_u8(bitbots::kGyroOdr, 5);
  store_u8(bitbots::kAccelOdr, 15);
  store_u8(bitbots::kGyroRange, 3);
  store_u8(bitbots::kAccelRange, 1);
  store_f32(bitbots::kAccelGain, 0.04f);
  store_f32(bitbots::kBiasAlpha, 0.01f);
  apply(ImuFeedback{});
}

void BitbotsImu::apply(const ImuFeedback& feedback) noexcept {
  const auto finite = [](double v) { return std::isfinite(v) ? static_cast<float>(v) : 0.0f; };
  store_f32(bitbots::kGyroX, finite(feedback.w_WS_S_rad_s[0]));
  store_f32(bitbots::kGyroY, finite(feedback.w_WS_S_rad_s[1]));
  store_f32(bitbots::kGyroZ, finite(feedback.w_WS_S_rad_s[2]));
  store_f32(bitbots::kAccelX, finite(feedback.a_WS_S_m_s2[0]));
  store_f32(bitbots::kAccelY, finite(feedback.a_WS_S_m_s2[1]));
  store_f32(bitbots::kAccelZ, finite(feedback.a_WS_S_m_s2[2]));
  // Orientation of S in a gravity-aligned frame, yaw-pitch-roll (ZYX) order.
  const double cr = std::cos(finite(feedback.roll_rad) / 2.0), sr = std::sin(finite(feedback.roll_rad) / 2.0);
  const double cp = std::cos(finite(feedback.pitch_rad) / 2.0), sp = std::sin(finite(feedback.pitch_rad) / 2.0);
  const double cy = std::cos(finite(feedback.yaw_rad) / 2.0), sy = std::sin(finite(feedback.yaw_rad) / 2.0);
  store_f32(bitbots::kQuaternionX, static_cast<float>(sr * cp * cy - cr * sp * sy));
  store_f32(bitbots::kQuaternionY, static_cast<float>(cr * sp * cy + sr * cp * sy));
  store_f32(bitbots::kQuaternionZ, static_cast<float>(cr * cp * sy - sr * sp * cy));
  store_f32(bitbots::kQuaternionW, static_cast<float>(cr * cp * cy + sr * sp * sy));
}

BitFoot::BitFoot(uint8_t id, uint8_t baud_raw, const BitFootCalibration& calibration)
    : BitbotsBoard(p2_board_spec(P2DeviceKind::kBitFoot), kFootItems, id, baud_raw), calibration_(calibration) {
  if (!(calibration.newton_per_count != 0.0) || !std::isfinite(calibration.newton_per_count) ||
      !std::isfinite(calibration.zero_counts)) {
    throw std::invalid_argument(std::string(model_name()) + ": newton_per_count must be finite and non-zero");
  }
  apply(FootFeedback{});
}

void BitFoot::apply(const FootFeedback& feedback) noexcept {
  const uint16_t addresses[4] = {bitbots::kSensor0, bitbots::kSensor1, bitbots::kSensor2, bitbots::kSensor3};
  for (std::size_t i = 0; i < 4; ++i) {
    const double force = std::isfinite(feedback.force_n[i]) ? feedback.force_n[i] : 0.0;
    const double raw = calibration_.zero_counts + force / calibration_.newton_per_count;
    if (calibration_.float32) {
      store_f32(addresses[i], static_cast<float>(raw));
    } else {
      const auto counts = static_cast<int32_t>(std::llround(std::clamp(raw, -2147483648.0, 2147483647.0)));
      store_u32(addresses[i], static_cast<uint32_t>(counts));
    }
  }
}

BitbotsCore::BitbotsCore(uint8_t id, uint8_t baud_raw)
    : BitbotsBoard(p2_board_spec(P2DeviceKind::kBitbotsCore), kCoreItems, id, baud_raw) {
  store_u8(bitbots::kPower, 1);
  apply(0.0, 0.0);
}

void BitbotsCore::apply(double supply_v, double current_a) noexcept {
  const bool on = power_on();
  store_u16(bitbots::kVext, adc(kAdcVoltsPerCount, supply_v));
  store_u16(bitbots::kVcc, adc(kAdcVoltsPerCount, kVccV));
  store_u16(bitbots::kVdxl, adc(kAdcVoltsPerCount, on ? supply_v : 0.0));
  // Driver: A = (raw * 3.3 / 1024 - 2.5) / -0.066.
  const double current = std::isfinite(current_a) ? current_a : 0.0;
  store_u16(bitbots::kCurrent, adc(3.3 / 1024.0, 2.5 - 0.066 * (on ? current : 0.0)));
  store_u16(bitbots::kPowerSense, on ? 1 : 0);
  for (uint16_t cell = 0; cell < 6; ++cell) {
    store_u16(static_cast<uint16_t>(bitbots::kVbat0 + 2 * cell), adc(kAdcVoltsPerCount, supply_v * (cell + 1) / 6.0));
  }
}

}  // namespace doppel::dynamixel
