#include "physics/engines.h"

#include <stdexcept>

namespace doppel::physics {

std::unique_ptr<Backend> make_backend(std::string_view engine) {
  if (engine == "ode") {
    return make_ode_backend();
  }
  if (engine == "bullet") {
    return make_bullet_backend();
  }
  throw std::invalid_argument("unknown physics engine '" + std::string(engine) + "' (known: ode, bullet)");
}

std::vector<std::string> engine_names() { return {"ode", "bullet"}; }

}  // namespace doppel::physics
