#pragma once
// How far the carpet reaches from the centre spot: the field and its border strip on each side
// (the rule book's field dimensions, physics::FieldSpec). One rule for where a robot or a ball may
// be put and for the carpet the scene draws.

#include "physics/field.h"

namespace doppel::physics {

inline double carpet_half_length_m(const FieldSpec& field) noexcept {
  return 0.5 * field.field_length_m + field.border_strip_width_m;
}
inline double carpet_half_width_m(const FieldSpec& field) noexcept {
  return 0.5 * field.field_width_m + field.border_strip_width_m;
}

}  // namespace doppel::physics
