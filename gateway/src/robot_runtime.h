#pragma once
// One robot at run time: for each of its buses the device objects, the pseudo-terminal and the
// bus server (run on that bus' I/O thread), and the simulated joints and sensors behind them (run
// on the simulation thread). The two threads share only two snapshots per bus: commands (bus ->
// simulation) and feedback (simulation -> bus), so neither ever waits for the other.
// Until the physics engine drives the body, joints move kinematically (kinematic_joint.h), the
// IMU lies level and the feet carry the robot's weight evenly.

#include <array>
#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bus/bus_server.h"
#include "bus/pty_port.h"
#include "bus/snapshot.h"
#include "dynamixel/bitbots_boards.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/device_io.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/protocol1_servo.h"
#include "dynamixel/protocol2_servo.h"
#include "gateway/kinematic_joint.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"

namespace doppel::gateway {

// Mass the foot boards carry until the physics issue gives the robot a body (the 2011 KidSize
// robot: 21 servos of 72-125 g plus frame, electronics and battery).
inline constexpr double kKinematicRobotMassKg = 4.0;
inline constexpr double kGravityM_S2 = 9.80665;

inline constexpr std::size_t kMaxServos = dynamixel::BusDevices::kMaxDevices;
inline constexpr std::size_t kMaxBoards = 8;

struct BusCommands {
  std::array<dynamixel::ServoCommand, kMaxServos> servos{};  // by servo index on the bus
};

struct BusFeedback {
  std::array<dynamixel::ServoFeedback, kMaxServos> servos{};  // by servo index on the bus
  std::array<dynamixel::ImuFeedback, kMaxBoards> imus{};      // by IMU index on the bus
  std::array<dynamixel::FootFeedback, kMaxBoards> feet{};     // by foot-board index on the bus
};

class BusRuntime final : public bus::DeviceSync {
 public:
  // Builds the devices of `config`, opens the port at `link` and the server. Setup only; throws.
  BusRuntime(const BusConfig& config, const std::string& link, const Options& options);
  ~BusRuntime() override;

  void start(const std::atomic<bool>& stop, int rt_priority);  // serves until stop is true
  void join();

  // bus::DeviceSync, called on the bus thread around every dispatched packet. rt-safe.
  void before_dispatch() noexcept override;
  void after_dispatch() noexcept override;
  // Also without traffic, so that time passes for the devices (Protocol 2.0 Bus Watchdog). rt-safe.
  void on_tick() noexcept override;

  // Simulation thread: one step of dt_s at simulation time sim_time_ns. rt-safe.
  void simulate(double dt_s, int64_t sim_time_ns, double foot_force_n) noexcept;
  std::size_t foot_board_count() const noexcept { return feet_.size(); }

  std::string describe() const;
  std::string summary() const;

 private:
  BusConfig config_;
  // A servo, IMU or foot board of either protocol (exactly one pointer set).
  struct ServoRef {
    dynamixel::Protocol1Servo* p1 = nullptr;
    dynamixel::Protocol2Servo* p2 = nullptr;
  };
  struct ImuRef {
    dynamixel::FumanoidImu* fumanoid = nullptr;
    dynamixel::BitbotsImu* bitbots = nullptr;
  };
  struct FootRef {
    dynamixel::FumanoidFootBoard* fumanoid = nullptr;
    dynamixel::BitFoot* bitbots = nullptr;
  };

  std::vector<std::unique_ptr<dynamixel::Device>> devices_;  // owns every device on the bus
  std::vector<ServoRef> servos_;
  std::vector<ImuRef> imus_;
  std::vector<FootRef> feet_;
  std::vector<dynamixel::BitbotsCore*> cores_;
  std::vector<KinematicJoint> joints_;                        // one per servo, simulation thread only
  dynamixel::BusDevices bus_devices_;
  std::unique_ptr<bus::PtyPort> port_;
  std::unique_ptr<bus::BusServer> server_;
  bus::Snapshot<BusCommands> commands_;
  bus::Snapshot<BusFeedback> feedback_;
  std::thread thread_;
};

class RobotRuntime {
 public:
  RobotRuntime(const RobotConfig& config, std::size_t robot_index, const Options& options);

  void start(const std::atomic<bool>& stop, int rt_priority);  // serves until stop is true
  void join();
  // Simulation thread: one step. rt-safe.
  void simulate(double dt_s, int64_t sim_time_ns) noexcept;

  std::string describe() const;
  std::string summary() const;

 private:
  RobotConfig config_;
  std::size_t index_;
  std::vector<std::unique_ptr<BusRuntime>> buses_;
  std::size_t foot_boards_ = 0;
};

}  // namespace doppel::gateway
