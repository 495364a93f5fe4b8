#pragma once
// The faults facet: faults on demand (docs/faults.md) while a simulation runs; a replay shows the
// recorded ones instead.

#include <cstdint>
#include <vector>

#include "contract/error.h"
#include "faults/fault.h"

namespace doppel::contract {

// Faults on demand (docs/faults.md): every fault of the run (ended ones too) at `sim_time_s`.
struct FaultEntry {
  faults::Fault fault;
  bool active = false;  // in force now
  bool ended = false;   // its end has passed (cleared, or its duration ran out)
};
struct FaultList {
  double sim_time_s = 0.0;
  std::vector<FaultEntry> faults;
};
class Faults {
 public:
  virtual ~Faults() = default;
  virtual FaultList faults() = 0;
  // Adds a fault whose spec passed faults::check(); the target (robot, bus, device) is checked here
  // (kNotFound), and kConflict when the run has as many faults as it can hold. Its number.
  virtual Result<uint32_t> add_fault(const faults::FaultSpec& spec) = 0;
  // Ends fault `number` now (kNotFound: no such fault); clear_faults ends every one.
  virtual Outcome clear_fault(uint32_t number) = 0;
  virtual Outcome clear_faults() = 0;
};

}  // namespace doppel::contract
