#pragma once
// What a USB2AX adapter (Xevel/usb2ax, firmware version 5) does with each Protocol 1.0 packet the
// host sends, before anything reaches the bus: most packets pass through to the servos unchanged,
// but the adapter answers packets for its own ID 253 (PING, READ and WRITE of its 18-byte control
// table) and performs SYNC READ (0x84) itself by sending each listed servo a READ and gathering the
// answers into one status of its own. Written from firmware/lufa_usb2ax/USB2AX.c
// (process_incoming_USB_data), AX.c (sync_read, axReadPacket, local_read, local_write) and AX.h;
// see docs/devices.md. Pure logic: the bus layer dispatches the READs and adds time.

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamixel/packet.h"

namespace doppel::dynamixel {

class Usb2axFirmware {
 public:
  static constexpr uint8_t kId = 0xFD;                 // AX_ID_DEVICE
  static constexpr uint8_t kSyncReadInstruction = 0x84;  // AX_CMD_SYNC_READ
  static constexpr uint16_t kModelNumber = 0x4201;     // MODEL_NUMBER_H:L, "should not collide with Robotis"
  static constexpr uint8_t kFirmwareVersion = 5;
  static constexpr std::size_t kRegisterCount = 18;    // REG_TABLE_SIZE
  static constexpr uint8_t kUsartTimeoutAddress = 4;   // servo answer timeout, ticks of 20 µs (default 50)
  static constexpr uint8_t kSendTimeoutAddress = 5;    // USB send timeout, ticks of 20 µs (default 4)
  static constexpr int64_t kTickNs = 20'000;           // timer 0: 16 MHz / 8 / (0x27 + 1)
  static constexpr std::size_t kMaxSyncReadServos = 120;  // AX_SYNC_READ_MAX_DEVICES

  enum class Action : uint8_t {
    kPassThrough,       // the servos see the packet; the adapter says nothing
    kAnswer,            // the adapter answers (status()); the servos do not see the packet
    kAnswerAndPass,     // broadcast with LEN out of the adapter's range: a range error, and the bytes pass
    kSyncRead,          // the adapter reads servo_count() servos in turn (servo_read(i))
  };

  Usb2axFirmware() noexcept;

  // Decides what the adapter does with one framed packet from the host. rt-safe.
  Action handle(const InstructionPacket& packet) noexcept;
  // kAnswer / kAnswerAndPass, and after finish_sync_read(): the adapter's status bytes.
  const StatusPacket& status() const noexcept { return status_; }

  // kSyncRead: the servos to read, in the host's order, and the READ the adapter sends each one
  // (FF FF ID 04 02 ADDR N CK, axGetRegister).
  std::size_t servo_count() const noexcept { return servo_count_; }
  const InstructionPacket& servo_read(std::size_t index) noexcept;
  static constexpr std::size_t kServoReadBytes = 8;  // wire size of that READ
  // Bytes of a good answer: FF FF ID LEN ERR data[N] CK.
  std::size_t expected_answer_bytes() const noexcept { return static_cast<std::size_t>(sync_length_) + 6; }
  // What the adapter's UART received for the current servo within its timeout (the bytes of every
  // status on the wire in order; n = 0: nothing). It keeps the data of an answer of exactly
  // expected_answer_bytes() with a good checksum (ID and error byte are not checked, as
  // axReadPacket does not), else N bytes of 0xFF. Call once per servo, in order. rt-safe.
  void add_servo_answer(const uint8_t* bytes, std::size_t n) noexcept;
  // Builds FF FF FD (2 + N * servos) 00 data... CK into status(). rt-safe.
  const StatusPacket& finish_sync_read() noexcept;

  // Timeouts from the adapter's registers: how long it waits for each byte of a servo's answer
  // (USART_TIMEOUT) and how long bytes wait before going to the host (SEND_TIMEOUT). The timer
  // fires once the count exceeds the register, i.e. after (register + 1) ticks at most.
  int64_t usart_timeout_ns() const noexcept { return (registers_[kUsartTimeoutAddress] + 1) * kTickNs; }
  int64_t send_timeout_ns() const noexcept { return (registers_[kSendTimeoutAddress] + 1) * kTickNs; }

  const std::array<uint8_t, kRegisterCount>& registers() const noexcept { return registers_; }

 private:
  void answer(uint8_t error, const uint8_t* data, std::size_t n) noexcept;

  std::array<uint8_t, kRegisterCount> registers_{};
  StatusPacket status_{};
  InstructionPacket read_{};
  std::array<uint8_t, kMaxSyncReadServos> servo_ids_{};
  std::size_t servo_count_ = 0;
  uint8_t sync_address_ = 0;
  uint8_t sync_length_ = 0;
  std::array<uint8_t, 256> gathered_{};  // data gathered so far (at most 229 bytes fit the reply)
  std::size_t gathered_count_ = 0;
};

}  // namespace doppel::dynamixel
