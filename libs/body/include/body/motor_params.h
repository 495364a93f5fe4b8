#pragma once
// The one place where a servo model of the device registry (dynamixel/model_registry.h) becomes
// the plain motor numbers the physics simulates (physics::DcMotorParams): physics knows no model
// names, the registry knows no physics. Setup code.

#include <optional>
#include <string_view>

#include "physics/dc_motor.h"
#include "physics/robot_model.h"

namespace doppel::body {

// The motor constants of servo model `model`: the registry's defaults (`bam_model` 0), or BAM's
// identification M1..M6 (`bam_model` 1..6: its kt, R, armature and friction law, the friction
// acting powered too). Throws std::invalid_argument naming `model` and the known servo models
// when it is no servo, or naming the identification it lacks.
physics::DcMotorParams motor_params(std::string_view model, int bam_model = 0);

// As motor_params, nullopt for a name that is no servo model or an identification it lacks.
std::optional<physics::DcMotorParams> find_motor_params(std::string_view model, int bam_model = 0) noexcept;

// The lookup physics::compile_robot takes: find_motor_params.
physics::MotorCatalog motor_catalog();

}  // namespace doppel::body
