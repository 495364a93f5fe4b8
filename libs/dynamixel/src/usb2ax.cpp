#include "dynamixel/usb2ax.h"

#include <algorithm>

#include "dynamixel/protocol1.h"

namespace doppel::dynamixel {
namespace {

constexpr uint8_t kErrorRange = 0x08;            // AX_ERROR_RANGE
constexpr std::size_t kRxBufferBytes = 128;      // AX_BUFFER_SIZE
constexpr std::size_t kMaxReturnBytes = 235;     // AX_MAX_RETURN_PACKET_SIZE
constexpr std::size_t kPacketOverhead = 6;
constexpr uint8_t kStartWritable = 4;            // START_RW_ADDR
// min_vals of AX.c for addresses 4..17: USART_TIMEOUT_MIN 8, SEND_TIMEOUT_MIN 0, RECEIVE_TIMEOUT_MIN 10.
constexpr std::array<uint8_t, 14> kMinimum{8, 0, 10, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};

}  // namespace

Usb2axFirmware::Usb2axFirmware() noexcept {
  // regs[] of AX.c: model L/H, firmware version, ID, USART_TIMEOUT 50, SEND_TIMEOUT 4, RECEIVE_TIMEOUT 100.
  registers_ = {0x01, 0x42, kFirmwareVersion, kId, 50, 4, 100, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
}

void Usb2axFirmware::answer(uint8_t error, const uint8_t* data, std::size_t n) noexcept {
  encode_protocol1_status(kId, error, data, n, status_);
}

Usb2axFirmware::Action Usb2axFirmware::handle(const InstructionPacket& packet) noexcept {
  if (packet.protocol != Protocol::kV1) return Action::kPassThrough;
  const bool own = packet.id == kId;
  if (!own && packet.id != kBroadcastId) return Action::kPassThrough;
  // LEN (params + 2) outside 2..123 for its own ID or broadcast: a range error, and the bytes pass.
  const std::size_t length = static_cast<std::size_t>(packet.param_count) + 2;
  if (length > kMaxSyncReadServos + 3) {
    answer(kErrorRange, nullptr, 0);
    return Action::kAnswerAndPass;
  }
  // A bad checksum, an instruction it does not know, a broadcast other than SYNC READ: passed on.
  if (!packet.checksum_ok) return Action::kPassThrough;
  const uint8_t* p = packet.params.data();
  const std::size_t n = packet.param_count;
  if (packet.instruction == kSyncReadInstruction) {
    const auto servos = static_cast<uint8_t>(length - 4);  // uint8_t arithmetic, as in the firmware
    const uint8_t count = n >= 2 ? p[1] : 0;
    if (count == 0 || count > kRxBufferBytes - kPacketOverhead ||
        static_cast<std::size_t>(count) * servos > kMaxReturnBytes - kPacketOverhead) {
      answer(kErrorRange, nullptr, 0);
      return Action::kAnswer;
    }
    sync_address_ = p[0];
    sync_length_ = count;
    servo_count_ = servos;
    std::copy_n(p + 2, servos, servo_ids_.begin());
    gathered_count_ = 0;
    return Action::kSyncRead;
  }
  if (!own) return Action::kPassThrough;
  switch (packet.instruction) {
    case instruction::kPing:
      if (n != 0) return Action::kPassThrough;  // the firmware expects the checksum right after INST
      answer(0, nullptr, 0);
      return Action::kAnswer;
    case instruction::kRead: {
      if (n != 2) return Action::kPassThrough;
      const std::size_t top = static_cast<std::size_t>(p[0]) + p[1];
      if (p[1] == 0 || top > kRegisterCount) {
        answer(kErrorRange, nullptr, 0);
      } else {
        answer(0, registers_.data() + p[0], p[1]);
      }
      return Action::kAnswer;
    }
    case instruction::kWrite: {
      if (n < 1) return Action::kPassThrough;
      const uint8_t address = p[0];
      const std::size_t count = n - 1;
      bool ok = count != 0 && address + count <= kRegisterCount && address >= kStartWritable;
      for (std::size_t i = 0; ok && i < count; ++i) ok = p[1 + i] >= kMinimum[address - kStartWritable + i];
      if (ok) std::copy_n(p + 1, count, registers_.begin() + address);
      answer(ok ? 0 : kErrorRange, nullptr, 0);
      return Action::kAnswer;
    }
    default:
      return Action::kPassThrough;  // RESET and BOOTLOAD restart the adapter; not modelled
  }
}

const InstructionPacket& Usb2axFirmware::servo_read(std::size_t index) noexcept {
  read_.protocol = Protocol::kV1;
  read_.id = servo_ids_[std::min(index, kMaxSyncReadServos - 1)];
  read_.instruction = instruction::kRead;
  read_.checksum_ok = true;
  read_.param_count = 2;
  read_.params[0] = sync_address_;
  read_.params[1] = sync_length_;
  return read_;
}

void Usb2axFirmware::add_servo_answer(const uint8_t* bytes, std::size_t n) noexcept {
  const std::size_t expected = expected_answer_bytes();
  bool good = n == expected && bytes[0] == 0xFF && bytes[1] == 0xFF;
  // axReadPacket: the sum of bytes 2..end (ID to checksum) must be 255 mod 256.
  if (good) {
    unsigned sum = 0;
    for (std::size_t i = 2; i < n; ++i) sum += bytes[i];
    good = sum % 256 == 255;
  }
  for (std::size_t i = 0; i < sync_length_ && gathered_count_ < gathered_.size(); ++i) {
    gathered_[gathered_count_++] = good ? bytes[5 + i] : 0xFF;
  }
}

const StatusPacket& Usb2axFirmware::finish_sync_read() noexcept {
  answer(0, gathered_.data(), gathered_count_);
  return status_;
}

}  // namespace doppel::dynamixel
