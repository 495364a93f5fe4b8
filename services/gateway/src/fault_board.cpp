#include "fault_board.h"

#include "robot_runtime.h"

namespace doppel::gateway {

FaultBoard::FaultBoard(std::vector<RobotRuntime*> robots, const std::atomic<int64_t>& sim_time_ns)
    : robots_(std::move(robots)), sim_time_ns_(sim_time_ns) {}

std::string FaultBoard::target_problem(const faults::FaultSpec& spec, contract::ErrorKind& kind) const {
  kind = contract::ErrorKind::kNotFound;
  if (spec.robot >= robots_.size() || robots_[spec.robot] == nullptr) {
    return "field 'robot': no robot " + std::to_string(spec.robot) + " with faults (there are " +
           std::to_string(robots_.size()) + "; robots added while doppel runs take none)";
  }
  const RobotRuntime& robot = *robots_[spec.robot];
  const std::string who = "robot " + std::to_string(spec.robot) + " '" + robot.config().name + "'";
  if (spec.bus >= 0 && static_cast<std::size_t>(spec.bus) >= robot.bus_count()) {
    return "field 'bus': " + who + " has no bus " + std::to_string(spec.bus) + " (it has " +
           std::to_string(robot.bus_count()) + ")";
  }
  const faults::FaultKindInfo& info = faults::info(spec.kind);
  if (spec.bus >= 0 && spec.id >= 0 && info.scope != faults::FaultScope::kBus) {
    const std::string_view role = robot.bus(static_cast<std::size_t>(spec.bus)).device_role(spec.id);
    const std::string where = who + " bus " + std::to_string(spec.bus);
    if (role.empty()) return "field 'id': " + where + " has no device with ID " + std::to_string(spec.id);
    kind = contract::ErrorKind::kInvalid;
    const bool any_device = spec.kind == faults::FaultKind::kDead || spec.kind == faults::FaultKind::kLate;
    if (info.scope == faults::FaultScope::kServo && !any_device && role != "servo") {
      return "field 'id': ID " + std::to_string(spec.id) + " on " + where + " is not a servo (kind " + std::string(info.name) + " needs one)";
    }
    if (info.scope == faults::FaultScope::kSensor) {
      const bool imu = spec.kind == faults::FaultKind::kImuDropout || spec.kind == faults::FaultKind::kImuBias;
      if (role != (imu ? "imu" : "foot")) {
        return "field 'id': ID " + std::to_string(spec.id) + " on " + where + " is not " +
               (imu ? "an IMU" : "a foot board") + " (kind " + std::string(info.name) + " needs one)";
      }
    }
  }
  if (info.scope == faults::FaultScope::kSensor && spec.bus < 0) {
    const bool imu = spec.kind == faults::FaultKind::kImuDropout || spec.kind == faults::FaultKind::kImuBias;
    std::size_t boards = 0;
    for (std::size_t b = 0; b < robot.bus_count(); ++b) boards += imu ? robot.bus(b).imu_count() : robot.bus(b).foot_count();
    if (boards == 0) return "field 'robot': " + who + " has no " + (imu ? "IMU" : "foot board");
  }
  return "";
}

contract::Result<uint32_t> FaultBoard::add(const faults::FaultSpec& spec) {
  if (const std::string problem = faults::check(spec); !problem.empty()) {
    return contract::Error{contract::ErrorKind::kInvalid, problem};
  }
  contract::ErrorKind kind = contract::ErrorKind::kNotFound;
  if (const std::string problem = target_problem(spec, kind); !problem.empty()) return contract::Error{kind, problem};
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = sim_time_ns_.load(std::memory_order_relaxed);
  std::size_t free = slots_.size();
  for (std::size_t s = 0; s < slots_.size() && free == slots_.size(); ++s) {
    // A slot is free when empty or when its fault can never act again.
    if (slots_[s] == 0 || faults_[slots_[s] - 1].end_ns <= now) free = s;
  }
  if (free == slots_.size()) {
    return contract::Error{contract::ErrorKind::kConflict,
                           "at most " + std::to_string(faults::kMaxFaults) + " faults may act at once: clear one first"};
  }
  faults::Fault fault;
  fault.number = next_number_++;
  fault.spec = spec;
  fault.start_ns = spec.start_ns == faults::kNow ? now : spec.start_ns;
  fault.end_ns = spec.duration_ns == faults::kForever ? INT64_MAX : fault.start_ns + spec.duration_ns;
  faults_.push_back(fault);
  slots_[free] = fault.number;
  publish();
  return fault.number;
}

contract::Outcome FaultBoard::clear(uint32_t number) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (number == 0 || number > faults_.size()) {
    return contract::Outcome::fail(contract::ErrorKind::kNotFound, "no fault " + std::to_string(number) + " (there are " +
                                           std::to_string(faults_.size()) + ")");
  }
  const int64_t now = sim_time_ns_.load(std::memory_order_relaxed);
  faults::Fault& fault = faults_[number - 1];
  if (fault.end_ns > now) fault.end_ns = std::max(now, fault.start_ns);
  publish();
  return contract::Outcome::done();
}

contract::Outcome FaultBoard::clear_all() {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = sim_time_ns_.load(std::memory_order_relaxed);
  for (faults::Fault& fault : faults_) {
    if (fault.end_ns > now) fault.end_ns = std::max(now, fault.start_ns);
  }
  publish();
  return contract::Outcome::done();
}

contract::FaultList FaultBoard::list() {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = sim_time_ns_.load(std::memory_order_relaxed);
  contract::FaultList out;
  out.sim_time_s = static_cast<double>(now) * 1e-9;
  for (const faults::Fault& fault : faults_) {
    out.faults.push_back({fault, fault.active_at(now), fault.end_ns <= now});
  }
  return out;
}

void FaultBoard::publish() {
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (robots_[r] == nullptr) continue;
    for (std::size_t b = 0; b < robots_[r]->bus_count(); ++b) {
      faults::FaultTable table;
      for (std::size_t s = 0; s < slots_.size(); ++s) {
        if (slots_[s] == 0) continue;
        const faults::Fault& fault = faults_[slots_[s] - 1];
        const bool here = fault.spec.robot == r && (fault.spec.bus < 0 || fault.spec.bus == static_cast<int32_t>(b));
        if (!here || fault.end_ns <= fault.start_ns) continue;
        table.faults[s] = fault;
        table.count = s + 1;
      }
      robots_[r]->bus(b).set_faults(table);
    }
  }
}

}  // namespace doppel::gateway
