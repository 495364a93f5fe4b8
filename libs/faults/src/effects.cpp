#include "faults/effects.h"

#include <algorithm>
#include <cmath>

#include "dynamixel/protocol1.h"
#include "dynamixel/protocol2.h"

namespace doppel::faults {
namespace {

using K = FaultKind;

bool live(const Fault& f, int64_t t_ns) noexcept { return f.number != 0 && f.active_at(t_ns); }

bool on_servo(const Fault& f, uint32_t bus, uint8_t id) noexcept {
  return info(f.spec.kind).scope == FaultScope::kServo && f.spec.bus == static_cast<int32_t>(bus) && f.spec.id == id;
}

bool on_sensor(const Fault& f, uint32_t bus, uint8_t id) noexcept {
  return f.spec.bus < 0 || (f.spec.bus == static_cast<int32_t>(bus) && f.spec.id == id);
}

// The first byte after the header, the one that may be flipped: P1 `FF FF ID LEN ERR`, P2
// `FF FF FD 00 ID LEN_L LEN_H 55 ERR`. Flipping the error byte, a parameter or the checksum keeps
// the packet framed and breaks its checksum, as noise on the line does.
std::size_t first_flippable(const dynamixel::StatusPacket& packet) noexcept {
  const bool p2 = packet.size >= 4 && packet.bytes[2] == 0xFD && packet.bytes[3] == 0x00;
  return p2 ? 8 : 4;
}

// The random stream of a fault: its seed and its kind, so that two faults of different kinds with
// the same seed draw independently (a drop and a collision would otherwise strike together).
uint64_t stream(const Fault& f) noexcept { return mix(f.spec.seed, 0x100 + static_cast<uint64_t>(f.spec.kind)); }

}  // namespace

void apply_servo(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, dynamixel::ServoFeedback& feedback,
                 StuckHold& stuck) noexcept {
  bool stuck_seen = false;
  for (const Fault& f : in_use(table)) {
    if (!live(f, t_ns)) continue;
    if (f.spec.kind == K::kBrownout) {
      feedback.voltage_v = std::min(feedback.voltage_v, f.spec.value);
      continue;
    }
    if (!on_servo(f, bus, id)) continue;
    switch (f.spec.kind) {
      case K::kOverheat:
        feedback.temperature_c += f.spec.value * static_cast<double>(t_ns - f.start_ns) * 1e-9;
        break;
      case K::kOverload:
        feedback.overload = true;
        break;
      case K::kVoltage:
        feedback.voltage_v = f.spec.value;
        break;
      case K::kStuck:
        if (stuck.number != f.number) stuck = StuckHold{f.number, feedback.position_rad};
        stuck_seen = true;
        break;
      default:
        break;
    }
  }
  if (!stuck_seen) {
    stuck.number = 0;
  } else {
    feedback.position_rad = stuck.position_rad;
    feedback.velocity_rad_s = 0.0;
  }
  for (const Fault& f : in_use(table)) {
    if (live(f, t_ns) && f.spec.kind == K::kPositionNoise && on_servo(f, bus, id)) {
      // One draw per simulation millisecond: the noise is a function of the seed and the time.
      feedback.position_rad += f.spec.value * gaussian(stream(f), static_cast<uint64_t>(t_ns / 1'000'000));
    }
  }
}

double torque_scale(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, double nominal_supply_v) noexcept {
  double scale = 1.0;
  for (const Fault& f : in_use(table)) {
    if (!live(f, t_ns)) continue;
    if (f.spec.kind == K::kWeak && on_servo(f, bus, id)) scale *= f.spec.value;
    // A DC motor's stall torque is proportional to its voltage.
    if (f.spec.kind == K::kBrownout && nominal_supply_v > 0.0) scale *= std::clamp(f.spec.value / nominal_supply_v, 0.0, 1.0);
  }
  return scale;
}

bool unreachable(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns) noexcept {
  for (const Fault& f : in_use(table)) {
    if (!live(f, t_ns)) continue;
    if (f.spec.kind == K::kSilent && f.spec.bus == static_cast<int32_t>(bus)) return true;
    if (f.spec.kind == K::kDead && on_servo(f, bus, id)) return true;
  }
  return false;
}

bool apply_imu(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, dynamixel::ImuFeedback& feedback) noexcept {
  for (const Fault& f : in_use(table)) {
    if (!live(f, t_ns) || !on_sensor(f, bus, id)) continue;
    if (f.spec.kind == K::kImuDropout) return false;
    if (f.spec.kind == K::kImuBias) {
      for (double& w : feedback.w_WS_S_rad_s) w += f.spec.value;
    }
  }
  return true;
}

bool apply_foot(const FaultTable& table, uint32_t bus, uint8_t id, int64_t t_ns, dynamixel::FootFeedback& feedback) noexcept {
  for (const Fault& f : in_use(table)) {
    if (!live(f, t_ns) || !on_sensor(f, bus, id)) continue;
    if (f.spec.kind == K::kFootDropout) return false;
    if (f.spec.kind == K::kFootBias) {
      for (double& force : feedback.force_n) force += f.spec.value;
    }
  }
  return true;
}

void apply_power(const FaultTable& table, int64_t t_ns, dynamixel::PowerFeedback& feedback) noexcept {
  for (const Fault& f : in_use(table)) {
    if (live(f, t_ns) && f.spec.kind == K::kBrownout) feedback.supply_v = std::min(feedback.supply_v, f.spec.value);
  }
}

double WireFaults::draw(const Fault& fault, std::size_t slot) noexcept {
  if (slot_number_[slot] != fault.number) {
    slot_number_[slot] = fault.number;
    draws_[slot] = 0;
  }
  return uniform(stream(fault), draws_[slot]++);
}

std::span<const dynamixel::OutgoingStatus> WireFaults::apply(const FaultTable& table, uint32_t bus, int64_t t_ns,
                                                             const dynamixel::InstructionPacket& instruction,
                                                             std::span<const dynamixel::OutgoingStatus> statuses) noexcept {
  bool any = false;
  for (const Fault& f : in_use(table)) {
    if (!live(f, t_ns) || f.spec.bus != static_cast<int32_t>(bus)) continue;
    const K kind = f.spec.kind;
    if (kind == K::kCorrupt || kind == K::kDrop || kind == K::kCollision || kind == K::kLate) any = true;
  }
  if (!any) return statuses;

  std::size_t n = 0;
  for (const dynamixel::OutgoingStatus& status : statuses) {
    if (status.packet == nullptr || n >= out_.size()) continue;
    dynamixel::OutgoingStatus o = status;
    bool keep = true;
    bool copied = false;
    for (std::size_t slot = 0; slot < in_use(table).size() && keep; ++slot) {
      const Fault& f = table.faults[slot];
      if (!live(f, t_ns) || f.spec.bus != static_cast<int32_t>(bus)) continue;
      switch (f.spec.kind) {
        case K::kLate:
          if (f.spec.id == status.device_id) {
            o.extra_delay_ns += static_cast<int64_t>(std::llround(f.spec.value * 1000.0));
            ++counters_.delayed;
          }
          break;
        case K::kDrop:
          if (draw(f, slot) < f.spec.rate) {
            keep = false;
            ++counters_.dropped;
          }
          break;
        case K::kCorrupt: {
          if (draw(f, slot) >= f.spec.rate) break;
          if (!copied) {
            packets_[n] = *status.packet;
            o.packet = &packets_[n];
            copied = true;
          }
          dynamixel::StatusPacket& p = packets_[n];
          const std::size_t first = first_flippable(p);
          if (p.size <= first) break;
          const uint64_t pick = mix(stream(f) ^ 0x5A5A5A5A5A5A5A5Aull, draws_[slot]);
          const std::size_t at = first + static_cast<std::size_t>(pick % (p.size - first));
          p.bytes[at] = static_cast<uint8_t>(p.bytes[at] ^ (1u << ((pick >> 32) % 8)));
          ++counters_.corrupted;
          break;
        }
        default:
          break;
      }
    }
    if (keep) out_[n++] = o;
  }

  // A stray answer: a device that should be silent sends an empty status at the same time as the
  // first answer (the wire carries the AND of both), or alone when nobody answers.
  for (std::size_t slot = 0; slot < in_use(table).size(); ++slot) {
    const Fault& f = table.faults[slot];
    if (!live(f, t_ns) || f.spec.kind != K::kCollision || f.spec.bus != static_cast<int32_t>(bus)) continue;
    if (draw(f, slot) >= f.spec.rate) continue;
    dynamixel::StatusPacket stray;
    const auto id = static_cast<uint8_t>(f.spec.id);
    const bool ok = instruction.protocol == dynamixel::Protocol::kV2
                        ? dynamixel::encode_protocol2_status(id, 0, nullptr, 0, stray)
                        : dynamixel::encode_protocol1_status(id, 0, nullptr, 0, stray);
    if (!ok) continue;
    ++counters_.stray;
    if (n == 0) {
      packets_[0] = stray;
      out_[0] = dynamixel::OutgoingStatus{&packets_[0], id, 0, false, false, 0, false};
      n = 1;
      continue;
    }
    dynamixel::StatusPacket& first = packets_[out_.size() - 1];
    first = *out_[0].packet;
    const uint16_t common = std::min(first.size, stray.size);
    for (uint16_t i = 0; i < common; ++i) first.bytes[i] = static_cast<uint8_t>(first.bytes[i] & stray.bytes[i]);
    out_[0].packet = &first;
    out_[0].collision = true;
  }
  return {out_.data(), n};
}

}  // namespace doppel::faults
