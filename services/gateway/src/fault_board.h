#pragma once
// Every fault of a run (docs/faults.md): added by the control API, doppel-ctl or a scenario,
// checked against the robots (robot, bus, device), numbered, and handed to each bus' threads as
// its faults::FaultTable (a snapshot per bus for the bus thread and one for the simulation thread,
// so neither ever waits). A fault keeps its table slot while it may act, so that its random
// stream runs on undisturbed when others come and go. Requests are serialized by a mutex on this
// side only. Faults act on the robots doppel started with, not on robots added while it runs.

#include <array>
#include <atomic>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "contract/faults.h"
#include "faults/fault.h"

namespace doppel::gateway {

class RobotRuntime;

class FaultBoard {
 public:
  // `robots` (by index) and `sim_time_ns` (the simulation time, ns) outlive the board. Setup.
  FaultBoard(std::vector<RobotRuntime*> robots, const std::atomic<int64_t>& sim_time_ns);

  // Adds a fault that passed faults::check(): starting at its start (kNow: the current simulation
  // time), for its duration. 404 naming the field for a robot, bus or device that is not there,
  // 400 for a device of the wrong kind, 409 when kMaxFaults may act at once already.
  contract::Result<uint32_t> add(const faults::FaultSpec& spec);
  // Fault `number` ends now (an ended one keeps its end); 404 if there is none.
  contract::Outcome clear(uint32_t number);
  contract::Outcome clear_all();
  contract::FaultList list();

 private:
  std::string target_problem(const faults::FaultSpec& spec, contract::ErrorKind& kind) const;
  // Every bus' table from slots_. Under mutex_.
  void publish();

  std::vector<RobotRuntime*> robots_;
  const std::atomic<int64_t>& sim_time_ns_;
  std::mutex mutex_;
  std::vector<faults::Fault> faults_;                  // every fault of the run, by number - 1
  std::array<uint32_t, faults::kMaxFaults> slots_{};   // the fault in each table slot (0: free)
  uint32_t next_number_ = 1;
};

}  // namespace doppel::gateway
