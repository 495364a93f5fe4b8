// FACTORY RESET, REBOOT, CLEAR and CONTROL TABLE BACKUP: the instructions that reset or store the table.
#include <algorithm>

#include "dynamixel/protocol2_device.h"

namespace doppel::dynamixel {

namespace {

constexpr uint8_t kClearMultiTurn = 0x01;
constexpr uint8_t kClearMagic[4] = {0x44, 0x58, 0x4C, 0x22};  // "DXL\""
constexpr uint8_t kBackupStore = 0x01;
constexpr uint8_t kBackupRestore = 0x02;
constexpr uint8_t kBackupMagic[4] = {0x43, 0x54, 0x52, 0x4C};  // "CTRL"
constexpr uint8_t kResetAll = 0xFF;
constexpr uint8_t kResetExceptId = 0x01;
constexpr uint8_t kResetExceptIdAndBaud = 0x02;

bool magic_matches(const uint8_t* p, const uint8_t (&magic)[4]) noexcept {
  return std::equal(magic, magic + 4, p);
}

}  // namespace

uint8_t Protocol2Device::maintenance_error(const InstructionPacket& packet) const noexcept {
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  switch (packet.instruction) {
    case instruction::kFactoryReset:
      if (n != 1) {
        return p2_error::kDataLength;
      }
      return p[0] == kResetAll || p[0] == kResetExceptId || p[0] == kResetExceptIdAndBaud ? 0 : p2_error::kDataRange;
    case instruction::kReboot:
      return n != 0 ? p2_error::kDataLength : 0;
    case instruction::kClear:
      if (n != 5) {
        return p2_error::kDataLength;
      }
      // Other options (0x02 clear errors) are DYNAMIXEL-Y only.
      return p[0] == kClearMultiTurn && magic_matches(p + 1, kClearMagic) ? 0 : p2_error::kDataRange;
    default:
      if (!spec_.table_backup) {
        return p2_error::kInstruction;  // CONTROL TABLE BACKUP is not in this model's firmware
      }
      if (n != 5) {
        return p2_error::kDataLength;
      }
      if ((p[0] != kBackupStore && p[0] != kBackupRestore) || !magic_matches(p + 1, kBackupMagic)) {
        return p2_error::kDataRange;
      }
      return torque_enabled() || (p[0] == kBackupRestore && !has_backup_) ? p2_error::kResultFail : 0;
  }
}

void Protocol2Device::run_maintenance(const InstructionPacket& packet) noexcept {
  const uint8_t option = packet.params[0];
  switch (packet.instruction) {
    case instruction::kFactoryReset: {
      if (packet.id == kBroadcastId && option == kResetAll) {
        return;  // ignored (fw >= 42): it would give every device ID 1
      }
      const uint8_t old_id = table_[x430::kId];
      const uint8_t old_baud = table_[x430::kBaudRate];
      load_defaults(false);
      if (option != kResetAll) {
        table_[x430::kId] = old_id;
      }
      if (option == kResetExceptIdAndBaud) {
        table_[x430::kBaudRate] = old_baud;
      }
      break;
    }
    case instruction::kControlTableBackup:
      if (option == kBackupStore) {
        std::copy_n(table_.begin(), backup_.size(), backup_.begin());
        has_backup_ = true;
        return;
      }
      for (const P2RegisterSpec& r : spec_.registers) {
        if (r.area == Area::kEeprom && r.access == Access::kReadWrite) {
          std::copy_n(backup_.begin() + r.address, r.size, table_.begin() + r.address);
        }
      }
      break;  // restoring reboots the device
    default:
      break;
  }
  reboot();
}

}  // namespace doppel::dynamixel
