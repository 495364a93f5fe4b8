#pragma once
// Which USB adapter sits between the host and a bus (docs/devices.md). Its own header so that
// configuration code can name it without the server.

#include <cstdint>

namespace doppel::bus {

// kFtdi: an FTDI FT232 as in the U2D2; bytes pass both ways and its latency timer
// (BusServerOptions::adapter_latency_ms) holds what goes to the host. kUsb2ax: a USB2AX (CDC-ACM, no
// latency timer): it answers its own ID 253 and SYNC READ 0x84 itself (dynamixel::Usb2axFirmware)
// and hands bytes to the host after its send timeout.
enum class AdapterProfile : uint8_t { kFtdi, kUsb2ax };

}  // namespace doppel::bus
