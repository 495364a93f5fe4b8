#pragma once
// A contract::Simulation that accepts every command and reports an empty world: the tests of one
// facet of the control API (faults, the world-model sensor) need a simulation beside that facet,
// and derive from this one, overriding only what they look at.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "contract/simulation.h"

namespace doppel::testing {

class NullSimulation : public contract::Simulation {
 public:
  contract::SimState state() override { return {}; }
  contract::Outcome pause() override { return {}; }
  contract::Outcome resume() override { return {}; }
  contract::Outcome step(uint32_t) override { return {}; }
  contract::Outcome reset() override { return {}; }
  contract::Outcome place(std::size_t, double, double, double) override { return {}; }
  contract::Outcome push(std::size_t, double, double, double, uint32_t) override { return {}; }
  contract::Outcome ball(double, double) override { return {}; }
  contract::Scene scene() override { return {}; }
  std::vector<contract::BusTable> buses() override { return {}; }
  contract::Result<contract::CameraStill> camera_still(const std::string&) override {
    return contract::Error{contract::ErrorKind::kNotFound, "no camera"};
  }
};

}  // namespace doppel::testing
