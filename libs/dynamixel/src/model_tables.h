#pragma once
// Private helpers shared by the model registry (model_registry.cpp) and the register lookups of
// models.cpp and protocol2_models.cpp: the register lookup and the list of known names for error
// messages. Not part of the public API.

#include <span>
#include <string>

#include "dynamixel/models.h"

namespace doppel::dynamixel::detail {

// The register (RegisterSpec or P2RegisterSpec) whose bytes contain `address`; nullptr for none.
// rt-safe.
template <class Register, class Address>
const Register* register_containing(std::span<const Register> registers, Address address) noexcept {
  for (const Register& r : registers) {
    if (address >= r.address && address < r.address + r.size) {
      return &r;
    }
  }
  return nullptr;
}

// "A, B, C": the names of `models` (ModelSpec or P2ModelSpec) for an "unknown model" message. Setup only.
template <class Model>
std::string model_names(std::span<const Model* const> models) {
  std::string names;
  for (const Model* m : models) {
    names += names.empty() ? "" : ", ";
    names += m->name;
  }
  return names;
}

}  // namespace doppel::dynamixel::detail
