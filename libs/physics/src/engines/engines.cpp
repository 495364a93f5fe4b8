#include "physics/engines.h"

#include <stdexcept>

namespace doppel::physics {

std::string_view engine_name(Engine engine) noexcept {
  switch (engine) {
    case Engine::kOde:
      return "ode";
    case Engine::kBullet:
      return "bullet";
  }
  return "?";
}

Engine engine_from_name(std::string_view name) {
  for (Engine engine : kEngines) {
    if (engine_name(engine) == name) {
      return engine;
    }
  }
  throw std::invalid_argument("unknown physics engine '" + std::string(name) + "' (known: ode, bullet)");
}

std::vector<std::string> engine_names() {
  std::vector<std::string> names;
  for (Engine engine : kEngines) {
    names.emplace_back(engine_name(engine));
  }
  return names;
}

std::unique_ptr<Backend> make_backend(Engine engine) {
  switch (engine) {
    case Engine::kOde:
      return make_ode_backend();
    case Engine::kBullet:
      return make_bullet_backend();
  }
  throw std::invalid_argument("make_backend: not an Engine value");
}

}  // namespace doppel::physics
