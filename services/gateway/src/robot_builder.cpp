#include "robot_builder.h"

#include "body/kinematic_body.h"
#include "body/physics_body.h"
#include "bus/latency_timer_files.h"
#include "camera/camera_config.h"
#include "eeprom_state.h"
#include "robot_names.h"
#include "robot_runtime.h"

namespace doppel::gateway {

std::unique_ptr<RobotRuntime> RobotBuilder::runtime(const RobotConfig& config, std::size_t robot,
                                                    std::optional<std::size_t> in_world, const RobotEeprom* saved,
                                                    const std::string& state_path) const {
  std::unique_ptr<body::SimulatedBody> body;
  if (in_world) {
    body = std::make_unique<body::PhysicsBody>(*world_, *in_world);
  } else {
    body = std::make_unique<body::KinematicBody>();
  }
  return std::make_unique<RobotRuntime>(config, robot, std::move(body), options_, saved, state_path);
}

std::string RobotBuilder::camera_name(std::size_t robot, const std::string& name) {
  return robot_camera_name(robot, name);
}

std::vector<CameraSetup> RobotBuilder::cameras(std::size_t robot, std::vector<CameraSetup> cameras) {
  for (CameraSetup& setup : cameras) setup.config.name = camera_name(robot, setup.config.name);
  return cameras;
}

truth::RobotBinding RobotBuilder::truth_binding(const RobotConfig& config, std::size_t in_world, uint8_t team) {
  truth::RobotBinding binding;
  binding.in_world = in_world;
  binding.team = team;
  if (!config.cameras.empty()) {
    binding.has_camera = true;
    binding.camera_body = config.cameras.front().body;
    binding.X_BC = camera::camera_pose_W(config.cameras.front().config.mount, Eigen::Isometry3d::Identity());
  }
  return binding;
}

contract::RobotAdded RobotBuilder::listing(std::size_t robot, const RobotConfig& config, RobotRuntime& runtime,
                                          const std::vector<std::string>& camera_names, const Topics& topics) {
  contract::RobotAdded added{static_cast<uint32_t>(robot), config.name, {}};
  for (std::size_t b = 0; b < runtime.bus_count(); ++b) {
    const std::string link = runtime.bus(b).link();
    const std::string bus_name = "ttyDXL" + std::to_string(b);
    added.links.push_back({"bus", bus_name, link});
    added.links.push_back({"latency_timer", bus_name, bus::LatencyTimerFiles::path_for_link(link)});
  }
  for (const std::string& name : camera_names) {
    added.links.push_back({"camera", name, "iceoryx:DoppelCamera/" + name + "/frames"});
  }
  for (const char* topic : {"world_model", "sensor_levels"}) {
    const bool published = std::string_view(topic) == "world_model" ? topics.world_model : topics.sensor_levels;
    if (!published || topics.transport == nullptr) continue;
    for (const std::string& location : truth::topic_locations(*topics.transport, robot, topic)) {
      added.links.push_back({topic, topic, location});
    }
  }
  return added;
}

}  // namespace doppel::gateway
