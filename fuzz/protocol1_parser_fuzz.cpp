// Arbitrary bytes through Protocol1Parser and a BusDevices with servos of every family and the
// FUmanoid boards. Must never crash; checks framing, status and counter invariants.
// Input: byte 0 picks the line rate, byte 1 drives the simulation feedback; the rest is the wire.
#include <cstdint>

#include "dynamixel/bus_devices.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/protocol1.h"
#include "dynamixel/protocol1_servo.h"
#include "fuzz_support.h"

namespace {

namespace dxl = doppel::dynamixel;
namespace fuzz = doppel::dynamixel::fuzz;

void check_status(const dxl::OutgoingStatus& s) {
  const dxl::StatusPacket& p = fuzz::checked_packet(s, 6, 259);
  if (s.collision) {
    return;  // garbled on purpose
  }
  FUZZ_CHECK(p.bytes[0] == 0xFF && p.bytes[1] == 0xFF);
  FUZZ_CHECK(p.bytes[2] == s.device_id);
  FUZZ_CHECK(p.bytes[4] <= 0x7F);
  fuzz::check_protocol1_frame(p);
}

struct Pristine {
  dxl::Protocol1Servo ax{dxl::model_spec("AX-12A"), 1, 1, 0};
  dxl::Protocol1Servo rx{dxl::model_spec("RX-64"), 2, 1, 0};
  dxl::Protocol1Servo mx28{dxl::model_spec("MX-28"), 3, 1, 0};
  dxl::Protocol1Servo mx106{dxl::model_spec("MX-106"), 4, 34, 0};
  dxl::FumanoidImu imu{100, 1, 0};
  dxl::FumanoidFootBoard foot{101, 1, 0};
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < fuzz::kWireStart) {
    return 0;
  }
  static constexpr uint32_t kRates[] = {1000000, 57600, 115200, 2250000};
  const uint32_t line_bps = fuzz::line_rate(data, kRates);

  // Built once (model lookup, factory defaults, power-on); each input starts from a copy, so every
  // input sees the same fresh devices without paying for their construction.
  static const Pristine pristine;
  dxl::Protocol1Servo ax(pristine.ax);
  dxl::Protocol1Servo rx(pristine.rx);
  dxl::Protocol1Servo mx28(pristine.mx28);
  dxl::Protocol1Servo mx106(pristine.mx106);
  dxl::FumanoidImu imu(pristine.imu);
  dxl::FumanoidFootBoard foot(pristine.foot);
  dxl::BusDevices bus;
  fuzz::add_all(bus, ax, rx, mx28, mx106, imu, foot);

  dxl::Protocol1Parser parser;
  uint64_t packets = 0;
  int64_t t_ns = 0;
  for (size_t i = fuzz::kWireStart; i < size; ++i) {
    if (parser.push(data[i]) != dxl::Protocol1Parser::Result::kPacket) {
      continue;
    }
    ++packets;
    const dxl::InstructionPacket& p = parser.packet();
    FUZZ_CHECK(p.param_count <= 253);
    FUZZ_CHECK(parser.idle());
    for (const dxl::OutgoingStatus& s : bus.dispatch(p, line_bps)) {
      check_status(s);
    }

    // Drive the simulation side of the devices the packet addressed (all for a broadcast) with
    // values derived from the input, including extremes. Stepping every device after every packet
    // made long inputs slow without reaching more code.
    const dxl::ServoFeedback fb = fuzz::feedback_at(data, i, 0.05, t_ns);
    const auto addressed = [&p](const dxl::Device& device) { return fuzz::addressed(p, device); };
    for (dxl::Protocol1Servo* servo : {&ax, &rx, &mx28, &mx106}) {
      if (!addressed(*servo)) continue;
      servo->apply(fb);
      const dxl::ServoCommand c = servo->command();
      FUZZ_CHECK(c.torque_limit_ratio >= 0.0 && c.torque_limit_ratio <= 1.0);
      FUZZ_CHECK(c.multi_turn || c.goal_position_rad >= c.min_position_rad - 1e-9 ||
                 c.max_position_rad < c.min_position_rad);
      FUZZ_CHECK(servo->id() <= 253);
    }
    if (addressed(imu)) {
      dxl::ImuFeedback imu_fb;
      imu_fb.sim_time_ns = t_ns;
      imu_fb.pitch_rad = fb.position_rad;
      imu_fb.w_WS_S_rad_s = {fb.velocity_rad_s * 1000, 0.0, -1e300};
      imu.apply(imu_fb);
    }
    if (addressed(foot)) {
      dxl::FootFeedback foot_fb;
      foot_fb.sim_time_ns = t_ns;
      foot_fb.force_n = {fb.temperature_c, -1.0, 1e9, fb.velocity_rad_s};
      foot.apply(foot_fb);
    }
  }
  const dxl::ParserCounters& c = parser.counters();
  FUZZ_CHECK(c.packets == packets);
  FUZZ_CHECK(c.bad_checksums <= c.packets);
  FUZZ_CHECK(bus.counters().instructions == packets);
  return 0;
}
