#pragma once
// The world-model facet: each robot's world-model virtual sensor (docs/multilevel.md), its settings
// read and changed while the simulation runs.

#include <cstddef>

#include "contract/error.h"
#include "contract/world_model_settings.h"

namespace doppel::contract {

class WorldModel {
 public:
  virtual ~WorldModel() = default;
  // Robot `robot`'s settings (kNotFound: no such robot or no sensor on it).
  virtual Result<WorldModelSettings> world_model(std::size_t robot) = 0;
  // A change applied from the robot's next message on, checked completely: a bad value is refused
  // with kInvalid naming its field. The settings now in force.
  virtual Result<WorldModelSettings> set_world_model(std::size_t robot, const WorldModelSettings& settings) = 0;
};

}  // namespace doppel::contract
