#include "faults/fault.h"

#include <cmath>
#include <numbers>

namespace doppel::faults {
namespace {

using K = FaultKind;
using S = FaultScope;

// Ranges: what a real servo, bus or supply can show. Temperatures rise at most 100 degC/s; voltages
// stay within what the servos' Present Voltage registers hold (0..25.5 V); noise and bias are small
// angles and forces; a late answer at most 100 ms (a host's timeout is shorter).
constexpr std::array<FaultKindInfo, kFaultKinds> kKinds{{
    {K::kOverheat, "overheat", S::kServo, "rise_c_per_s", 0.01, 100.0, false,
     "the motor temperature rises by rise_c_per_s from the start; the firmware's overheating error and shutdown follow"},
    {K::kOverload, "overload", S::kServo, "", 0, 0, false,
     "the motor controller reports overload while torque is on; error bit and shutdown follow"},
    {K::kVoltage, "voltage", S::kServo, "volts", 0.0, 25.5, false,
     "the servo measures `volts` at its input; outside its voltage limits: input-voltage error"},
    {K::kPositionNoise, "position_noise", S::kServo, "sigma_rad", 1e-6, 1.0, false,
     "Gaussian noise (sigma_rad) on the measured position, a new draw every simulation ms"},
    {K::kStuck, "stuck", S::kServo, "", 0, 0, false, "the measured position stays where it was at the start"},
    {K::kWeak, "weak", S::kServo, "scale", 0.0, 1.0, false, "the motor gives `scale` of its torque"},
    {K::kDead, "dead", S::kServo, "", 0, 0, false, "the servo neither sees packets nor answers"},
    {K::kLate, "late", S::kServo, "delay_us", 1.0, 100'000.0, false, "its statuses leave delay_us later"},
    {K::kCorrupt, "corrupt", S::kBus, "", 0, 0, true, "a status has one byte flipped with probability `rate`"},
    {K::kDrop, "drop", S::kBus, "", 0, 0, true, "a status is lost with probability `rate`"},
    {K::kSilent, "silent", S::kBus, "", 0, 0, false, "the cable is unplugged: no device sees packets or answers"},
    {K::kCollision, "collision", S::kBus, "", 0, 0, true,
     "with probability `rate` per instruction, device `id` sends a status although it should be silent"},
    {K::kBrownout, "brownout", S::kRobot, "volts", 0.0, 25.5, false,
     "the servo supply sags to `volts`: every servo measures it, motors lose torque, power boards read it"},
    {K::kImuDropout, "imu_dropout", S::kSensor, "", 0, 0, false, "the IMU's readings freeze"},
    {K::kImuBias, "imu_bias", S::kSensor, "bias", -10.0, 10.0, false, "`bias` rad/s added to each gyro axis"},
    {K::kFootDropout, "foot_dropout", S::kSensor, "", 0, 0, false, "the foot board's readings freeze"},
    {K::kFootBias, "foot_bias", S::kSensor, "bias", -500.0, 500.0, false, "`bias` N added to each load cell"},
}};

// "an overheat fault", "a silent fault".
std::string a_fault(FaultKind kind) {
  const std::string name(kKinds[static_cast<std::size_t>(kind)].name);
  return (name.find_first_of("aeiou") == 0 ? "an " : "a ") + name + " fault";
}

std::string number_text(double x) {
  std::string s = std::to_string(x);
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

}  // namespace

const std::array<FaultKindInfo, kFaultKinds>& fault_kinds() noexcept { return kKinds; }

const FaultKindInfo& info(FaultKind kind) noexcept { return kKinds[static_cast<std::size_t>(kind)]; }

std::optional<FaultKind> fault_kind(std::string_view name) noexcept {
  for (const FaultKindInfo& k : kKinds) {
    if (k.name == name) return k.kind;
  }
  return std::nullopt;
}

std::string fault_kind_names() {
  std::string out;
  for (const FaultKindInfo& k : kKinds) out += (out.empty() ? "" : ", ") + std::string(k.name);
  return out;
}

std::string check(const FaultSpec& spec) {
  const FaultKindInfo& k = info(spec.kind);
  switch (k.scope) {
    case S::kServo:
      if (spec.bus < 0) return "missing field 'bus' (" + a_fault(spec.kind) + " names a servo: robot, bus, id)";
      if (spec.id < 0) return "missing field 'id' (" + a_fault(spec.kind) + " names a servo: robot, bus, id)";
      break;
    case S::kBus:
      if (spec.bus < 0) return "missing field 'bus' (" + a_fault(spec.kind) + " names a bus: robot, bus)";
      if (spec.kind == K::kCollision && spec.id < 0) return "missing field 'id' (the device that answers although it should not)";
      if (spec.kind != K::kCollision && spec.id >= 0) return "field 'id' does not belong to " + a_fault(spec.kind) + " (it acts on the whole bus)";
      break;
    case S::kRobot:
      if (spec.bus >= 0) return "field 'bus' does not belong to " + a_fault(spec.kind) + " (it acts on the whole robot)";
      if (spec.id >= 0) return "field 'id' does not belong to " + a_fault(spec.kind) + " (it acts on the whole robot)";
      break;
    case S::kSensor:
      if ((spec.bus < 0) != (spec.id < 0)) return "fields 'bus' and 'id' go together (one board), or neither (every such board of the robot)";
      break;
  }
  if (spec.id > 253) return "field 'id' must be within 0..253, got " + std::to_string(spec.id);
  if (spec.start_ns != kNow && (spec.start_ns < 0 || static_cast<double>(spec.start_ns) > kMaxStartS * 1e9)) {
    return "field 'start_s' must be within 0.." + number_text(kMaxStartS) + " s";
  }
  if (spec.duration_ns < 0 || spec.duration_ns > kMaxDurationNs) {
    return "field 'duration_s' must be within 0.." + number_text(static_cast<double>(kMaxDurationNs) * 1e-9) +
           " s (0: until cleared)";
  }
  if (!k.value_field.empty()) {
    if (!std::isfinite(spec.value) || spec.value < k.value_min || spec.value > k.value_max) {
      return "field '" + std::string(k.value_field) + "' must be within " + number_text(k.value_min) + ".." +
             number_text(k.value_max) + " for " + a_fault(spec.kind) + ", got " + number_text(spec.value);
    }
  }
  if (k.needs_rate && (!std::isfinite(spec.rate) || spec.rate <= 0.0 || spec.rate > 1.0)) {
    return "field 'rate' must be within (0, 1] for " + a_fault(spec.kind) + ", got " + number_text(spec.rate);
  }
  return "";
}

uint64_t mix(uint64_t seed, uint64_t n) noexcept {
  // splitmix64 (Steele, Lea, Flood 2014) of the seed's stream at position n.
  uint64_t z = seed * 0x9E3779B97F4A7C15ull + (n + 1) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double uniform(uint64_t seed, uint64_t n) noexcept { return static_cast<double>(mix(seed, n) >> 11) * 0x1.0p-53; }

double gaussian(uint64_t seed, uint64_t n) noexcept {
  // Box-Muller on two draws of the stream.
  const double u1 = 1.0 - uniform(seed, 2 * n);  // (0, 1]
  const double u2 = uniform(seed, 2 * n + 1);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
}

}  // namespace doppel::faults
