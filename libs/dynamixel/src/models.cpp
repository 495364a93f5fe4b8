#include "dynamixel/models.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "model_tables.h"

namespace doppel::dynamixel {

const RegisterSpec* find_register(std::span<const RegisterSpec> registers, uint8_t address) noexcept {
  return detail::register_containing(registers, address);
}

uint32_t p1_baud_bps(uint8_t raw, bool mx_codes) noexcept {
  if (mx_codes) {
    switch (raw) {
      case 250:
        return 2250000;
      case 251:
        return 2500000;
      case 252:
        return 3000000;
      default:
        break;
    }
  }
  return 2000000u / (raw + 1u);
}

uint8_t p1_baud_register(uint32_t bps, const ModelSpec& model) {
  int best = -1;
  double best_error = 0.0;
  // Value 0 (2 Mbps) is listed for the MX series only (reference §3.2); AX/RX top out at 1 Mbps.
  for (int raw = model.mx_baud_codes ? 0 : 1; raw <= 254; ++raw) {
    const double rate = p1_baud_bps(static_cast<uint8_t>(raw), model.mx_baud_codes);
    const double error = std::abs(rate - bps) / static_cast<double>(bps == 0 ? 1 : bps);
    if (best < 0 || error < best_error) {
      best = raw;
      best_error = error;
    }
  }
  if (bps == 0 || best_error > 0.03) {
    throw std::invalid_argument(std::string(model.name) + " cannot run at " + std::to_string(bps) +
                                " bps: no Baud Rate register value within 3 %");
  }
  return static_cast<uint8_t>(best);
}

}  // namespace doppel::dynamixel
