// Protocol Type 1: the X control table served by the Protocol 1.0 front end, P2 errors mapped to P1 bits.
#include "dynamixel/protocol2_device.h"

#include "protocol1_front_end.h"

namespace doppel::dynamixel {

namespace {

// The Protocol 1.0 error bit (§1.4) for a Protocol 2.0 error number (§2.5), assumption: a Data
// Limit on Goal Position is the Angle Limit bit, every other refused value, length or address the
// Range bit.
uint8_t p1_bits(uint8_t p2_error_number, bool goal_position_written) noexcept {
  switch (p2_error_number) {
    case 0:
      return 0;
    case p2_error::kInstruction:
    case p2_error::kResultFail:
      return p1_error::kInstruction;
    case p2_error::kCrc:
      return p1_error::kChecksum;
    case p2_error::kDataLimit:
      return goal_position_written ? p1_error::kAngleLimit : p1_error::kRange;
    default:
      return p1_error::kRange;
  }
}

bool covers_goal_position(std::size_t start, std::size_t n) noexcept {
  return start < x430::kGoalPosition + 4u && x430::kGoalPosition < start + n;
}

}  // namespace

class Protocol2Device::Protocol1Registers final : public Protocol1RegisterFile {
 public:
  explicit Protocol1Registers(Protocol2Device& device) noexcept : device_(device) {}

  uint8_t id() const noexcept override { return device_.id(); }
  bool answers(uint8_t instruction_code) const noexcept override { return device_.answers(instruction_code); }
  bool has_bulk_read() const noexcept override { return true; }
  const uint8_t* read(uint8_t start, uint8_t length) noexcept override {
    return device_.read(start, length, device_.scratch_.data()) ? device_.scratch_.data() : nullptr;
  }
  uint8_t write(uint16_t start, const uint8_t* data, std::size_t n, bool commit) noexcept override {
    return p1_bits(device_.write(start, data, n, commit, false), covers_goal_position(start, n));
  }
  HeldWrite& held_write() noexcept override { return device_.held_write_; }
  void set_registered(bool registered) noexcept override {
    device_.table_[x430::kRegisteredInstruction] = registered ? 1 : 0;
  }
  // P1 RESET has no option: everything to factory values, Protocol Type 2 included.
  void factory_reset() noexcept override {
    device_.load_defaults(false);
    device_.reboot();
  }
  // Hardware Error Status bits 0 (input voltage), 2 (overheating) and 5 (overload) sit where the P1
  // error byte has the same conditions (§1.4, §3.7); the encoder and shock bits have no P1 place.
  uint8_t condition_bits() const noexcept override {
    constexpr uint8_t kSharedBits = x430::kInputVoltageError | x430::kOverheatingError | x430::kOverloadError;
    return static_cast<uint8_t>(device_.hardware_error() & kSharedBits);
  }
  void on_communication() noexcept override { device_.on_communication(); }

 private:
  Protocol2Device& device_;
};

void Protocol2Device::handle_protocol1(const InstructionPacket& packet, Response& response) noexcept {
  Protocol1Registers registers{*this};
  detail::handle_protocol1(registers, counters_, packet, response);
}

}  // namespace doppel::dynamixel
