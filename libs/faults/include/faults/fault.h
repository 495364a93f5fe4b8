#pragma once
// Faults on demand (docs/faults.md): what can go wrong with a servo, a bus or a robot's supply and
// sensors, when (simulation time) and for how long, as plain values. A fault changes only what a
// real one would change: the measurements a device's firmware sees (it then reacts as it does to a
// real overheating or brown-out), the drive a motor gets, or the bytes on the wire. The control
// API, doppel-ctl and scenario files describe faults with FaultSpec; the gateway hands the active
// ones to its bus and simulation threads as a FaultTable (fixed size: copying it allocates nothing).

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>

namespace doppel::faults {

enum class FaultKind : uint8_t {
  // servo (robot, bus, id)
  kOverheat,       // temperature ramps up by `value` degC/s from the fault's start
  kOverload,       // the motor controller reports overload (while torque is on)
  kVoltage,        // the servo measures `value` V at its supply input
  kPositionNoise,  // Gaussian noise of `value` rad on the measured position
  kStuck,          // the measured position stays where it was when the fault started
  kWeak,           // the motor gives `value` (0..1) of its torque
  kDead,           // the servo neither sees packets nor answers
  kLate,           // its statuses leave `value` us later
  // bus (robot, bus)
  kCorrupt,    // a status has one byte flipped with probability `rate` (checksum error at the host)
  kDrop,       // a status is lost with probability `rate`
  kSilent,     // the bus is cut: no device sees packets, nothing answers
  kCollision,  // with probability `rate` per instruction, device `id` answers although it should not
  // robot (robot; sensors: optionally one device by bus and id)
  kBrownout,     // the servo supply sags to `value` V
  kImuDropout,   // the IMU's readings freeze
  kImuBias,      // `value` rad/s added to each gyro axis
  kFootDropout,  // the foot board's readings freeze
  kFootBias,     // `value` N added to each load cell
};
inline constexpr std::size_t kFaultKinds = 17;

enum class FaultScope : uint8_t { kServo, kBus, kRobot, kSensor };

// What one kind needs: its name, scope and the JSON / scenario name and range of its `value` or
// `rate` (field empty: the kind takes none).
struct FaultKindInfo {
  FaultKind kind;
  std::string_view name;
  FaultScope scope;
  std::string_view value_field;  // "" = none
  double value_min, value_max;   // inclusive
  bool needs_rate;               // `rate` in (0, 1]
  std::string_view what;         // one line for help texts
};
const std::array<FaultKindInfo, kFaultKinds>& fault_kinds() noexcept;
const FaultKindInfo& info(FaultKind kind) noexcept;
std::optional<FaultKind> fault_kind(std::string_view name) noexcept;
// Every kind's name, comma-separated (for error messages).
std::string fault_kind_names();

inline constexpr int64_t kNow = -1;       // FaultSpec::start_ns: when the request is applied
inline constexpr int64_t kForever = 0;    // FaultSpec::duration_ns: until cleared
inline constexpr int64_t kMaxDurationNs = 3'600'000'000'000;  // one hour of simulation
inline constexpr double kMaxStartS = 86'400.0;

struct FaultSpec {
  FaultKind kind = FaultKind::kOverheat;
  uint32_t robot = 0;
  int32_t bus = -1;   // -1: none (robot faults: every bus; sensor faults: every such sensor of the robot)
  int32_t id = -1;    // servo, sensor or (collision) the stray device's ID; -1: none
  int64_t start_ns = kNow;
  int64_t duration_ns = kForever;
  double value = 0.0;
  double rate = 0.0;
  uint64_t seed = 1;
};

// "" when `spec` is complete for its kind, else what is wrong, naming the field as the control API
// and scenario files call it ('bus', 'id', 'rise_c_per_s', 'rate', 'duration_s', ...). Robot, bus
// and ID are checked against the robots by the gateway.
std::string check(const FaultSpec& spec);

// A fault as the gateway holds it: its number (1, 2, ... per run) and when it is in force,
// simulation ns, [start_ns, end_ns).
struct Fault {
  uint32_t number = 0;
  FaultSpec spec;
  int64_t start_ns = 0;
  int64_t end_ns = INT64_MAX;
  bool active_at(int64_t t_ns) const noexcept { return t_ns >= start_ns && t_ns < end_ns; }
};

// The faults that concern one bus (its own and its robot's), for its threads. Plain values.
inline constexpr std::size_t kMaxFaults = 32;
struct FaultTable {
  std::array<Fault, kMaxFaults> faults{};
  std::size_t count = 0;  // slots from here on are empty (a fault keeps its slot while in force)
};

// The slots that may hold a fault: the effects loop over these only, so that a bus without faults
// (the usual case) pays nothing per packet or measurement for them. rt-safe.
inline std::span<const Fault> in_use(const FaultTable& table) noexcept {
  return {table.faults.data(), std::min(table.count, kMaxFaults)};
}

// A counter-based random number generator: the n-th draw of a stream depends only on its seed and
// n, so a fault replays the same way for the same traffic. rt-safe.
uint64_t mix(uint64_t seed, uint64_t n) noexcept;
double uniform(uint64_t seed, uint64_t n) noexcept;    // [0, 1)
double gaussian(uint64_t seed, uint64_t n) noexcept;   // mean 0, standard deviation 1

}  // namespace doppel::faults
