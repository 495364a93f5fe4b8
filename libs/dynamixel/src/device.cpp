#include "dynamixel/device.h"

namespace doppel::dynamixel {

std::string Device::restore_eeprom(std::span<const uint8_t> bytes) {
  return bytes.empty() ? std::string() : std::string(model_name()) + " keeps no EEPROM";
}

std::string Device::write_item(uint16_t, int64_t) {
  return std::string(model_name()) + " takes no initial register values";
}

}  // namespace doppel::dynamixel
