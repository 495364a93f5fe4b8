#pragma once
// Chooses a physics engine (`doppel --physics ode|bullet`). Lives in its own target,
// doppel::physics_engines, which links both backends; code that wants one engine only can link
// doppel::physics_ode or doppel::physics_bullet and call its factory directly.

#include <array>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "physics/backend.h"

namespace doppel::physics {

enum class Engine { kOde, kBullet };

inline constexpr std::array<Engine, 2> kEngines{Engine::kOde, Engine::kBullet};

// The engine's name on the command line and in test names: "ode", "bullet".
std::string_view engine_name(Engine engine) noexcept;

// The engine called `name`; throws std::invalid_argument naming the known engines otherwise.
Engine engine_from_name(std::string_view name);

// The names of kEngines, in order.
std::vector<std::string> engine_names();

std::unique_ptr<Backend> make_ode_backend();     // in doppel::physics_ode
std::unique_ptr<Backend> make_bullet_backend();  // in doppel::physics_bullet

std::unique_ptr<Backend> make_backend(Engine engine);

}  // namespace doppel::physics
