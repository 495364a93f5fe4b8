#pragma once
// Chooses a physics engine by name (`doppel --physics ode|bullet`). Lives in its own target,
// doppel::physics_engines, which links both backends; code that wants one engine only can link
// doppel::physics_ode or doppel::physics_bullet and call its factory directly.

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "physics/backend.h"

namespace doppel::physics {

std::unique_ptr<Backend> make_ode_backend();     // in doppel::physics_ode
std::unique_ptr<Backend> make_bullet_backend();  // in doppel::physics_bullet

// "ode" or "bullet"; throws std::invalid_argument naming the known engines otherwise.
std::unique_ptr<Backend> make_backend(std::string_view engine);

// The names make_backend() accepts.
std::vector<std::string> engine_names();

}  // namespace doppel::physics
