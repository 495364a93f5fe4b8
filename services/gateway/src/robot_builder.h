#pragma once
// How one robot is built into a running doppel, for the robots it starts with (Gateway) and those
// added while it runs (LiveRobots): its runtime (body, buses, devices, ports), the names its
// cameras stream under, how the world-model sensor follows it, and the listing of where its links,
// streams and topics are (contract::RobotAdded). One place, so the two paths cannot drift apart.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "contract/robot_host.h"
#include "eeprom_state.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "truth/transport.h"
#include "truth/truth_service.h"

namespace doppel::physics {
class World;
}

namespace doppel::gateway {

class RobotRuntime;

class RobotBuilder {
 public:
  // `world`: where robots with a body live (null: every robot moves kinematically). Both outlive
  // this object and the runtimes it builds.
  RobotBuilder(const Options& options, physics::World* world) : options_(options), world_(world) {}

  // Robot `robot`'s runtime; its body is the world's robot `in_world` (kinematic when nullopt).
  // `saved`: EEPROM areas from the state file `state_path` (null = none). Setup; throws.
  std::unique_ptr<RobotRuntime> runtime(const RobotConfig& config, std::size_t robot, std::optional<std::size_t> in_world,
                                        const RobotEeprom* saved = nullptr, const std::string& state_path = "") const;

  // The name robot `robot`'s camera `name` streams under: as the file says for robot 0, else
  // "robot<r>-name", so that every camera's name is unique on the machine (README, docs/cameras.md).
  static std::string camera_name(std::size_t robot, const std::string& name);
  // Robot `robot`'s cameras with the names they stream under.
  static std::vector<CameraSetup> cameras(std::size_t robot, std::vector<CameraSetup> cameras);

  // How the world-model sensor follows a robot that is the world's robot `in_world`: its head
  // camera (the file's first camera) when it has one, else its heading.
  static truth::RobotBinding truth_binding(const RobotConfig& config, std::size_t in_world, uint8_t team);

  // Where robot `robot`'s parts are: every bus' link and latency-timer file, every camera stream
  // (`camera_names`, as streamed) and the truth topics it is published on (`transport` null: none).
  struct Topics {
    const truth::TransportOptions* transport = nullptr;
    bool world_model = false;
    bool sensor_levels = false;
  };
  static contract::RobotAdded listing(std::size_t robot, const RobotConfig& config, RobotRuntime& runtime,
                                     const std::vector<std::string>& camera_names, const Topics& topics);

 private:
  const Options& options_;
  physics::World* world_;
};

}  // namespace doppel::gateway
