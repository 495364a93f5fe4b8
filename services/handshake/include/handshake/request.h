#pragma once
// From the wire to contract::RobotHost and back: every field of a request is checked here before
// the host is asked, so a bad request is refused naming its proto field path
// ("add_robot.camera[1].width_px") and nothing is built. What only the host can know (does the
// robot file exist, has it a camera of that name) the host checks; its refusal names a
// contract::RobotRequest field, which proto_field_path() turns into the same kind of path.

#include <string>
#include <string_view>
#include <variant>

#include "contract/robot_host.h"
#include "proto/handshake.pb.h"

namespace doppel::handshake {

namespace wire = doppel::proto::handshake;

// The request as the host takes it, or the first field that is wrong (field: a proto path).
std::variant<contract::RobotRequest, contract::Refusal> check_add_robot(const wire::AddRobot& message);

// A contract::RobotRequest field as the host names it ("cameras[0].noise_gaussian_sigma",
// "world_model.fov_deg", "") to the proto path of the same field
// ("add_robot.camera[0].noise.gaussian_sigma", "add_robot.world_model.fov_deg", "add_robot").
std::string proto_field_path(std::string_view host_field);

// A robot as the wire has it (token empty: the caller adds it where the client may have it).
wire::Robot to_wire(const contract::RobotAdded& robot);

}  // namespace doppel::handshake
