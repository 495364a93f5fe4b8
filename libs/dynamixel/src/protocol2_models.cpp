#include "dynamixel/protocol2_models.h"

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#include "model_tables.h"

namespace doppel::dynamixel {

namespace {

constexpr std::array<uint32_t, 8> kBaudTable{9600, 57600, 115200, 1000000, 2000000, 3000000, 4000000, 4500000};

}  // namespace

const P2RegisterSpec* find_p2_register(std::span<const P2RegisterSpec> registers, uint16_t address) noexcept {
  return detail::register_containing(registers, address);
}

uint32_t p2_baud_bps(uint8_t raw, bool baud7_is_5m) noexcept {
  if (raw >= kBaudTable.size()) {
    return 0;
  }
  if (raw == 7 && baud7_is_5m) {
    return 5000000;
  }
  return kBaudTable[raw];
}

uint8_t p2_baud_register(uint32_t bps, const P2ModelSpec& model) {
  std::string rates;
  for (uint8_t raw = 0; raw < kBaudTable.size(); ++raw) {
    const uint32_t rate = p2_baud_bps(raw, model.baud7_is_5m);
    if (bps != 0 && std::abs(static_cast<double>(rate) - bps) <= 0.03 * bps) {
      return raw;
    }
    rates += (rates.empty() ? "" : ", ") + std::to_string(rate);
  }
  throw std::invalid_argument(std::string(model.name) + " cannot run at " + std::to_string(bps) +
                              " bps; its Baud Rate register offers " + rates + " bps");
}

}  // namespace doppel::dynamixel
