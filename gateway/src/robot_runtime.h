#pragma once
// One robot at run time: for each of its buses the device objects, the pseudo-terminal and the
// bus server (run on that bus' I/O thread), and what drives the devices' registers on the
// simulation thread: the servo firmware's motor controller and a motor of the physics world, or,
// for a robot without a body, a kinematic joint. The two threads share only two snapshots per bus:
// commands (bus -> simulation) and feedback (simulation -> bus), so neither waits for the other.

#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "bus/bus_server.h"
#include "bus/pty_port.h"
#include "concurrency/snapshot.h"
#include "dynamixel/bitbots_boards.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/device_io.h"
#include "dynamixel/fumanoid_boards.h"
#include "dynamixel/protocol1_servo.h"
#include "dynamixel/protocol2_servo.h"
#include "dynamixel/servo_controller.h"
#include "gateway/kinematic_joint.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "physics/world.h"

namespace doppel::gateway {

// Mass the foot boards of a robot without a body carry (the 2011 KidSize robot: 21 servos of
// 72-125 g plus frame, electronics and battery).
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

// Where the simulation finds a robot's body: the world and the robot's index in it.
struct BodyRef {
  physics::World* world = nullptr;  // nullptr: the robot moves kinematically
  std::size_t robot = 0;            // index of the robot in the world
};

class BusRuntime final : public bus::DeviceSync {
 public:
  // Builds the devices of `config` (bus `bus_index` of its robot), links servos and sensors to
  // `body` where its figure has them, opens the port at `link` and the server. Setup; throws.
  BusRuntime(const BusConfig& config, std::size_t bus_index, BodyRef body, const std::string& link,
             const Options& options);
  ~BusRuntime() override;

  void start(const std::atomic<bool>& stop, int rt_priority);  // serves until stop is true
  void join();

  // bus::DeviceSync, called on the bus thread around every dispatched packet. rt-safe.
  void before_dispatch() noexcept override;
  void after_dispatch() noexcept override;
  // Also without traffic, so that time passes for the devices (Protocol 2.0 Bus Watchdog). rt-safe.
  void on_tick() noexcept override;

  // Simulation thread, before the world steps: runs every servo's motor controller on the latest
  // commands and hands the result to the world (or moves the kinematic joints). rt-safe.
  void drive(double dt_s) noexcept;
  // Simulation thread, after the world stepped: publishes what the devices measure. rt-safe.
  void sense(int64_t sim_time_ns, double kinematic_cell_force_n) noexcept;

  std::size_t foot_board_count() const noexcept { return feet_.size(); }
  std::string describe() const;
  std::string summary() const;

 private:
  // One servo (any protocol) and what moves it.
  struct ServoSlot {
    ServoSlot(dynamixel::SimulatedServo& servo, const dynamixel::ServoControllerConfig& controller_config,
              double no_load_speed_rad_s)
        : device(&servo), controller(controller_config), joint(no_load_speed_rad_s) {}
    dynamixel::SimulatedServo* device;
    std::optional<physics::MotorHandle> motor;  // its motor in the world, if the figure has one
    dynamixel::ServoController controller;      // the firmware's motor controller (physics only)
    KinematicJoint joint;                        // used when there is no motor
    double position_rad = 0.0;                   // last measured, for the controller
    double velocity_rad_s = 0.0;
  };
  struct ImuSlot {
    dynamixel::SimulatedImu* device = nullptr;
    std::optional<physics::ImuHandle> imu;
  };
  struct FootSlot {
    dynamixel::SimulatedFootBoard* device = nullptr;
    std::optional<physics::FootHandle> foot;
  };

  void add_servo(dynamixel::SimulatedServo& servo, const dynamixel::ServoSpec& spec, const std::string& model,
                 uint8_t id);

  BusConfig config_;
  std::size_t bus_index_;
  BodyRef body_;
  std::vector<std::unique_ptr<dynamixel::Device>> devices_;  // owns every device on the bus
  std::vector<ServoSlot> servos_;                             // simulation state: simulation thread only
  std::vector<ImuSlot> imus_;
  std::vector<FootSlot> feet_;
  std::vector<dynamixel::BitbotsCore*> cores_;
  dynamixel::BusDevices bus_devices_;
  std::unique_ptr<bus::PtyPort> port_;
  std::unique_ptr<bus::BusServer> server_;
  concurrency::Snapshot<BusCommands> commands_;
  concurrency::Snapshot<BusFeedback> feedback_;
  std::thread thread_;
};

class RobotRuntime {
 public:
  RobotRuntime(const RobotConfig& config, std::size_t robot_index, BodyRef body, const Options& options);

  void start(const std::atomic<bool>& stop, int rt_priority);  // serves until stop is true
  void join();
  // Simulation thread, around one world step (see BusRuntime). rt-safe.
  void drive(double dt_s) noexcept;
  void sense(int64_t sim_time_ns) noexcept;

  std::string describe() const;
  std::string summary() const;

 private:
  RobotConfig config_;
  std::size_t index_;
  BodyRef body_;
  std::vector<std::unique_ptr<BusRuntime>> buses_;
  std::size_t foot_boards_ = 0;
};

}  // namespace doppel::gateway
