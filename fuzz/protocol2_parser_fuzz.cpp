// Arbitrary bytes through the Protocol 2.0 parser, the mixed P1/P2 framer and a BusDevices with
// X-series servos, the Bit-Bots boards and a Protocol 1.0 servo on the same bus. Must never crash;
// checks framing, stuffing round trips, status and counter invariants.
// Input: byte 0 picks the line rate, byte 1 drives the simulation feedback; the rest is the wire.
#include <cstdint>

#include "dynamixel/bitbots_boards.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/packet_framer.h"
#include "dynamixel/protocol1_servo.h"
#include "dynamixel/protocol2.h"
#include "dynamixel/protocol2_servo.h"
#include "fuzz_support.h"

namespace {

namespace dxl = doppel::dynamixel;
namespace fuzz = doppel::dynamixel::fuzz;

// A P2 status (or fast-read block) as it leaves the device.
void check_status(const dxl::OutgoingStatus& s) {
  const dxl::StatusPacket& p = fuzz::checked_packet(s, 4, dxl::kMaxStatusBytes);
  if (s.collision || s.continues_previous) {
    return;  // garbled on purpose / a later block of a combined status (no header)
  }
  FUZZ_CHECK(p.bytes[0] == 0xFF && p.bytes[1] == 0xFF);
  if (p.bytes[2] != 0xFD) {
    // Protocol 1.0 status from the MX-28.
    fuzz::check_protocol1_frame(p);
    return;
  }
  FUZZ_CHECK(p.size >= 11);
  FUZZ_CHECK(p.bytes[3] == 0x00 && p.bytes[7] == 0x55);
  const std::size_t length = p.bytes[5] | (p.bytes[6] << 8);
  if (p.bytes[4] == 0xFE) {
    return;  // first block of a fast-read status: LEN covers blocks still to come
  }
  FUZZ_CHECK(length + 7 == p.size);
  const uint16_t crc = dxl::protocol2_crc(p.bytes.data(), p.size - 2);
  FUZZ_CHECK(p.bytes[p.size - 2] == (crc & 0xFF) && p.bytes[p.size - 1] == (crc >> 8));
  FUZZ_CHECK((p.bytes[8] & 0x7F) <= 7);
}

struct Pristine {
  dxl::Protocol2Servo xm1{dxl::p2_model_spec("XM430-W350"), 1, 6, 0};
  dxl::Protocol2Servo xm2{dxl::p2_model_spec("XM430-W350"), 2, 3, 0};
  dxl::Protocol2Servo xl3{dxl::p2_model_spec("XL430-W250"), 3, 6, 250};
  dxl::BitbotsImu imu{241, 6};
  dxl::BitFoot foot{101, 6};
  dxl::BitbotsCore core{42, 6};
  dxl::Protocol1Servo mx{dxl::model_spec("MX-28"), 1, 1, 0};
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < fuzz::kWireStart) {
    return 0;
  }
  static constexpr uint32_t kRates[] = {4000000, 1000000, 57600, 2000000};
  const uint32_t line_bps = fuzz::line_rate(data, kRates);

  // Stuffing round trip on the raw input.
  static uint8_t stuffed[4096];
  static uint8_t back[4096];
  const std::size_t n_in = size < 1024 ? size : 1024;
  const std::size_t n_stuffed = dxl::protocol2_stuff(data, n_in, stuffed, sizeof stuffed);
  FUZZ_CHECK(n_stuffed >= n_in);
  FUZZ_CHECK(dxl::protocol2_unstuff(stuffed, n_stuffed, back) == n_in);
  for (std::size_t i = 0; i < n_in; ++i) {
    FUZZ_CHECK(back[i] == data[i]);
  }

  // Built once (model lookup, factory defaults, power-on); each input starts from a copy, so every
  // input sees the same fresh devices without paying for their construction.
  static const Pristine pristine;
  dxl::Protocol2Servo xm1(pristine.xm1);
  dxl::Protocol2Servo xm2(pristine.xm2);
  dxl::Protocol2Servo xl3(pristine.xl3);
  dxl::BitbotsImu imu(pristine.imu);
  dxl::BitFoot foot(pristine.foot);
  dxl::BitbotsCore core(pristine.core);
  dxl::Protocol1Servo mx(pristine.mx);
  dxl::BusDevices bus;
  fuzz::add_all(bus, xm1, xm2, xl3, imu, foot, core, mx);

  dxl::Protocol2Parser p2;
  dxl::PacketFramer framer;
  uint64_t p2_packets = 0;
  uint64_t framed = 0;
  int64_t t_ns = 0;
  for (size_t i = fuzz::kWireStart; i < size; ++i) {
    if (p2.push(data[i]) == dxl::Protocol2Parser::Result::kPacket) {
      ++p2_packets;
      FUZZ_CHECK(p2.packet().param_count <= dxl::kMaxInstructionParams);
      FUZZ_CHECK(p2.idle());
    }
    if (framer.push(data[i]) != dxl::PacketFramer::Result::kPacket) {
      continue;
    }
    ++framed;
    const dxl::InstructionPacket& p = framer.packet();
    FUZZ_CHECK(framer.idle());
    for (const dxl::OutgoingStatus& s : bus.dispatch(p, line_bps)) {
      check_status(s);
    }

    // Only the devices the packet addressed (all for a broadcast) step their simulation side.
    const dxl::ServoFeedback fb = fuzz::feedback_at(data, i, 0.5, t_ns);
    const auto addressed = [&p](const dxl::Device& device) { return fuzz::addressed(p, device); };
    for (dxl::Protocol2Servo* servo : {&xm1, &xm2, &xl3}) {
      if (!addressed(*servo)) continue;
      servo->apply(fb);
      const dxl::ServoCommand c = servo->command();
      FUZZ_CHECK(c.torque_limit_ratio >= 0.0 && c.torque_limit_ratio <= 1.0);
      FUZZ_CHECK(c.goal_position_rad >= c.min_position_rad - 1e-9 && c.goal_position_rad <= c.max_position_rad + 1e-9);
      FUZZ_CHECK(servo->id() <= 252);
      FUZZ_CHECK(!c.torque_enabled || servo->hardware_error() == 0);
    }
    if (addressed(imu)) {
      dxl::ImuFeedback imu_fb;
      imu_fb.roll_rad = fb.position_rad;
      imu_fb.w_WS_S_rad_s = {fb.velocity_rad_s * 1000, 0.0, -1e300};
      imu.apply(imu_fb);
    }
    if (addressed(foot)) {
      dxl::FootFeedback foot_fb;
      foot_fb.force_n = {fb.temperature_c, -1.0, 1e12, fb.velocity_rad_s};
      foot.apply(foot_fb);
    }
    if (addressed(core)) core.apply(fb.voltage_v, fb.torque_ratio);
  }
  FUZZ_CHECK(p2.counters().packets == p2_packets);
  FUZZ_CHECK(p2.counters().bad_checksums <= p2.counters().packets);
  FUZZ_CHECK(framer.counters().packets == framed);
  FUZZ_CHECK(bus.counters().instructions == framed);
  return 0;
}
