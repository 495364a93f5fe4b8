#pragma once
// One robot at run time: for each of its buses the device objects, the pseudo-terminal and the
// bus server (run on that bus' I/O thread), and the robot's simulated body (body/simulated_body.h:
// the physics world or kinematic joints), which the simulation thread drives with the servos'
// commands and reads the devices' measurements from. The two threads share only two snapshots per
// bus: commands (bus -> simulation) and feedback (simulation -> bus), so neither waits for the other.

#include <algorithm>
#include <array>
#include <atomic>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "bus/bus_server.h"
#include "bus/latency_timer_files.h"
#include "bus/pty_port.h"
#include "body/sensor_levels.h"
#include "body/simulated_body.h"
#include "concurrency/snapshot.h"
#include "contract/simulation.h"
#include "dynamixel/built_device.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/darwin_boards.h"
#include "dynamixel/protocol1_device.h"
#include "dynamixel/protocol2_device.h"
#include "dynamixel/device_io.h"
#include "eeprom_state.h"
#include "faults/effects.h"
#include "faults/fault.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"

namespace doppel::gateway {

inline constexpr std::size_t kMaxServos = dynamixel::BusDevices::kMaxDevices;
inline constexpr std::size_t kMaxBoards = 8;

struct BusCommands {
  std::array<dynamixel::ServoCommand, kMaxServos> servos{};  // by servo index on the bus
};

// Every device's EEPROM area as the bus thread last saw it (bus -> state thread).
inline constexpr std::size_t kMaxEepromBytes = 64;
struct BusEeprom {
  uint64_t generation = 0;  // +1 whenever some device's EEPROM changed
  std::array<std::array<uint8_t, kMaxEepromBytes>, kMaxServos> bytes{};  // by device index on the bus
};

struct BusFeedback {
  std::array<dynamixel::ServoFeedback, kMaxServos> servos{};  // by servo index on the bus
  std::array<dynamixel::ImuFeedback, kMaxBoards> imus{};      // by IMU index on the bus
  std::array<dynamixel::FootFeedback, kMaxBoards> feet{};     // by foot-board index on the bus
  dynamixel::PowerFeedback power{};                           // for every power board on the bus
};

// Every servo's registers as the viewer's servo table shows them (bus thread -> HTTP threads),
// decoded on the bus thread every kServoTableEveryTicks. Raw register values, model units.
inline constexpr int kServoTableEveryTicks = 10;  // bus ticks are 10 ms: every 100 ms
struct ServoRegisters {
  uint8_t id = 0;
  bool torque = false;
  int64_t goal_position = 0, present_position = 0, present_speed = 0, present_load = 0, temperature = 0, voltage = 0;
  int64_t error = -1;  // -1: no error register
};
struct BusServoTable {
  std::array<ServoRegisters, kMaxServos> servos{};  // by servo index on the bus
};

class BusRuntime final : public bus::DeviceSync {
 public:
  // Builds the devices of `config` (bus `bus_index` of its robot): factory defaults, then the
  // saved EEPROM areas `saved` (by device; null = none, use the file's initial EEPROM values), then
  // the initial RAM values; links servos and sensors to `body` (which outlives the bus), opens the
  // port and the server; the port's `link` appears once the bus is served (start(), or
  // publish_link() when another thread serves it). Setup; throws (naming `state_path` for a bad
  // saved EEPROM).
  BusRuntime(const BusConfig& config, std::size_t bus_index, body::SimulatedBody& body, const std::string& link,
             const Options& options, const std::vector<std::vector<uint8_t>>* saved = nullptr,
             const std::string& state_path = "");
  ~BusRuntime() override;

  // Starts the bus thread, which serves until stop is true, and publishes the link once it runs.
  // Setup; throws when the link cannot be published (the thread then runs until stop).
  void start(const std::atomic<bool>& stop, int rt_priority);
  void join();
  // Publishes the link without a bus thread (lockstep: the simulation thread serves the bus). Setup; throws.
  void publish_link();
  const std::string& slave_path() const noexcept { return port_->slave_path(); }  // /dev/pts/N

  // bus::DeviceSync, called on the bus thread around every dispatched packet. rt-safe.
  void before_dispatch() noexcept override;
  void after_dispatch() noexcept override;
  // Also without traffic, so that time passes for the devices (Protocol 2.0 Bus Watchdog). rt-safe.
  void on_tick() noexcept override;
  // The bus faults on the devices' statuses (late, lost, corrupted, stray). rt-safe.
  std::span<const dynamixel::OutgoingStatus> impair(const dynamixel::InstructionPacket& packet,
                                                    std::span<const dynamixel::OutgoingStatus> statuses) noexcept override;

  // The faults that concern this bus (faults/), for its bus thread and the simulation thread. One
  // writer at a time (the gateway's FaultBoard, under its mutex). rt-safe.
  void set_faults(const faults::FaultTable& table) noexcept {
    bus_faults_.publish(table);
    sim_faults_.publish(table);
  }
  // What the wire faults did so far (bus thread writes; the counters are plain, read for a summary).
  faults::WireCounters wire_fault_counters() const noexcept { return wire_counters_.latest_copy(); }

  // Simulation thread, before the world steps: hands every servo's latest command to the body. rt-safe.
  void drive(double dt_s) noexcept;
  // Simulation thread, after the world stepped: publishes what the devices measure; the power
  // boards measure `servo_current_a` drawn from the bus supply. rt-safe.
  void sense(int64_t sim_time_ns, double servo_current_a) noexcept;
  // A simulation reset: the bus thread power-cycles every device (RAM to its power-on values, then
  // the robot file's initial RAM values; EEPROM stays) within one tick (10 ms); until then drive()
  // hands no command to the body. Any thread, lock-free.
  void request_power_on() noexcept { power_on_requested_.fetch_add(1, std::memory_order_acq_rel); }

  // The listing at start: the link, and every device with the EEPROM items the state file changed
  // from the robot file and a flag when its baud rate is not the bus'.
  std::string describe() const;
  std::string summary() const;
  // What the device with ID `id` in the robot file is on this bus: "servo", "imu", "foot",
  // "board" (another device), or "" (no such ID). Setup data, any thread.
  std::string_view device_role(int32_t id) const noexcept;
  std::size_t imu_count() const noexcept { return imus_.size(); }
  std::size_t foot_count() const noexcept { return feet_.size(); }
  // How many devices' EEPROM (restored from a state file) differs from the robot file's.
  std::size_t devices_differing_from_file() const noexcept {
    return static_cast<std::size_t>(std::count_if(eeprom_changes_.begin(), eeprom_changes_.end(),
                                                  [](const std::string& c) { return !c.empty(); }));
  }

  bus::BusServer& server() noexcept { return *server_; }
  // Return Delay Time of device `index` (file order), µs; only while the bus thread is not running.
  uint32_t return_delay_us(std::size_t index) const noexcept { return devices_[index]->return_delay_us(); }
  // Where the bus reports its traffic when the run is recorded (--record); null otherwise.
  bus::TrafficTap* tap() noexcept { return tap_.get(); }
  const std::string& link() const noexcept { return port_->link_path(); }
  // State thread: the newest EEPROM areas the bus thread published (generation, bytes). rt-safe.
  const BusEeprom& published_eeprom() noexcept { return eeprom_.latest(); }
  // EEPROM bytes per device of `eeprom` (sizes of the devices' areas).
  std::vector<std::vector<uint8_t>> eeprom_bytes(const BusEeprom& eeprom) const;
  // The devices' EEPROM areas now; only while the bus thread is not running.
  std::vector<std::vector<uint8_t>> eeprom_now() const;
  std::vector<uint16_t> model_numbers() const;
  // The servo table (ID, name, model, registers) the bus thread published last. Any thread but
  // the bus thread (one at a time: a mutex on the reading side only).
  contract::BusTable servo_table();

  // Sensor levels (body/sensor_levels.h; TruthOptions::sensor_levels_hz > 0, else none). The levels
  // thread only: takes the newest sample the bus thread published (true when it is new), and the
  // sample itself. rt-safe.
  bool sensor_levels_enabled() const noexcept { return levels_ != nullptr; }
  bool update_sensor_levels() noexcept { return levels_ != nullptr && levels_->update(); }
  const body::BusLevelsSample& sensor_levels() noexcept { return levels_->latest(); }
  const body::BusLevelsLayout& sensor_levels_layout() const noexcept { return levels_layout_; }

 private:
  // Copies every sensor's registers with the feedback they were set from into a sensor-levels
  // sample when one is due in simulation time. Bus thread; rt-safe.
  void sample_sensor_levels(const BusFeedback& feedback) noexcept;
  // Decodes every servo's registers into servo_table_ and publishes them. Bus thread; rt-safe.
  void publish_servo_table() noexcept;
  // Where a servo's table columns are in its control table (-1: the model has no such register).
  enum Column : std::size_t { kTorque, kGoal, kPresent, kSpeed, kLoad, kTemperature, kVoltage, kError, kColumns };
  struct ServoColumns {
    std::size_t device_index;
    std::array<int32_t, kColumns> address;
  };
  // Compares every device's EEPROM with what was published and publishes a change. Bus thread; rt-safe.
  void publish_eeprom_changes() noexcept;
  // A device's simulation side and its index in the body.
  template <typename Role>
  struct Linked {
    Role* device;
    std::size_t body_index;
    std::size_t device_index;  // in devices_ and bus_devices_
  };
  // A device whose supply a sub-controller switches; exactly one of the two is set.
  struct Gated {
    std::size_t device_index;
    dynamixel::Protocol1Device* p1;
    dynamixel::Protocol2Device* p2;
  };

  void link_to_body(const dynamixel::DeviceRole& role, const DeviceConfig& device, std::size_t device_index);
  // Setup: a CM-730 on the bus switches every other device's supply with its Dynamixel Power.
  void wire_supply_switch();
  // After every packet: follows a change of Dynamixel Power (off: silent and limp; on: a power
  // cycle, RAM to power-on values). Bus thread; rt-safe.
  void follow_supply_switch() noexcept;

  BusConfig config_;
  std::size_t bus_index_;
  body::SimulatedBody& body_;                                 // the robot's; simulation thread only
  std::vector<std::unique_ptr<dynamixel::Device>> devices_;  // owns every device on the bus
  std::vector<Linked<dynamixel::SimulatedServo>> servos_;
  std::vector<Linked<dynamixel::SimulatedImu>> imus_;
  std::vector<Linked<dynamixel::SimulatedFootBoard>> feet_;
  std::vector<dynamixel::SimulatedPowerBoard*> power_boards_;
  dynamixel::BusDevices bus_devices_;
  const dynamixel::Cm730* supply_switch_ = nullptr;  // the bus' CM-730, if any
  bool supply_on_ = true;                            // bus thread: its Dynamixel Power as last followed
  std::vector<Gated> gated_;                         // the devices it switches
  std::vector<std::string> eeprom_changes_;  // by device: EEPROM items restored from the state file that the robot file sets otherwise ("" none)
  std::unique_ptr<bus::PtyPort> port_;
  std::unique_ptr<bus::TrafficTap> tap_;  // before server_, which writes it
  std::unique_ptr<bus::BusServer> server_;
  concurrency::Snapshot<BusCommands> commands_;
  concurrency::Snapshot<BusFeedback> feedback_;
  concurrency::Snapshot<BusEeprom> eeprom_;
  BusEeprom eeprom_seen_{};  // bus thread: the last published EEPROM areas
  // Power-on on request (request_power_on): every device as P1/P2 device, the RAM values of the
  // file's `initial` entries, and the requests seen / completed (commands published after it).
  struct RamValue {
    std::size_t device_index;
    uint16_t address;
    int64_t value;
  };
  std::vector<Gated> every_device_;
  std::vector<RamValue> initial_ram_;
  std::atomic<uint64_t> power_on_requested_{0};
  std::atomic<uint64_t> power_on_done_{0};
  uint64_t power_on_pending_ = 0;  // bus thread: the request being carried out, 0 = none
  std::vector<ServoColumns> servo_columns_;  // by servo index on the bus
  concurrency::Snapshot<BusServoTable> servo_table_;
  std::mutex servo_table_mutex_;  // reading side only: the snapshot has one reader
  int servo_table_ticks_ = 0;     // bus thread
  // Sensor levels: the layout (setup), each device's control table by device index, the snapshot
  // and the bus thread's sampling grid.
  body::BusLevelsLayout levels_layout_;
  std::vector<std::span<const uint8_t>> levels_tables_;
  std::unique_ptr<concurrency::Snapshot<body::BusLevelsSample>> levels_;
  int64_t levels_period_ns_ = 0;
  int64_t levels_last_ns_ = 0;
  int64_t levels_next_ns_ = 0;
  uint64_t levels_sequence_ = 0;
  // Faults (faults/): the table as the bus thread and the simulation thread read it, the bus
  // thread's wire faults and stuck positions (by servo index), and the simulation time each
  // thread last saw.
  concurrency::Snapshot<faults::FaultTable> bus_faults_;
  concurrency::Snapshot<faults::FaultTable> sim_faults_;
  std::unique_ptr<faults::WireFaults> wire_faults_ = std::make_unique<faults::WireFaults>();
  std::vector<faults::StuckHold> stuck_;
  int64_t bus_sim_now_ns_ = 0;  // bus thread
  int64_t sim_now_ns_ = 0;      // simulation thread
  struct WireCounterCopy {
    std::atomic<uint64_t> corrupted{0}, dropped{0}, delayed{0}, stray{0};
    faults::WireCounters latest_copy() const noexcept {
      return {corrupted.load(std::memory_order_relaxed), dropped.load(std::memory_order_relaxed),
              delayed.load(std::memory_order_relaxed), stray.load(std::memory_order_relaxed)};
    }
  } wire_counters_;
  std::atomic<uint64_t> collisions_{0};  // BusDevices' wire collisions, stored by the bus thread after each packet
  std::thread thread_;
};

class RobotRuntime {
 public:
  // `body`: the robot's body (a PhysicsBody in the gateway's world, or a KinematicBody). Setup; throws.
  // `saved`: EEPROM areas from the state file `state_path` (null = none). Setup; throws.
  RobotRuntime(const RobotConfig& config, std::size_t robot_index, std::unique_ptr<body::SimulatedBody> body,
               const Options& options, const RobotEeprom* saved = nullptr, const std::string& state_path = "");

  // Starts every bus thread and publishes each link once its thread runs (see BusRuntime::start).
  void start(const std::atomic<bool>& stop, int rt_priority);
  void join();
  // Publishes every bus' link (lockstep: the simulation thread serves the buses). Setup; throws.
  void publish_links();
  // Simulation thread, around one world step (see BusRuntime). rt-safe.
  void drive(double dt_s) noexcept;
  void sense(int64_t sim_time_ns) noexcept;
  // Simulation thread, after the world put the robot back (World::reset_robot): every servo of the
  // robot powers on again (body controllers, device RAM). rt-safe.
  void power_on() noexcept;

  // The listing at start: the robot, where its EEPROM state comes from and goes, every bus.
  std::string describe() const;
  std::string summary() const;

  // Gives every bus its latency-timer file beside its link. Setup; throws.
  void add_latency_timer_files(bus::LatencyTimerFiles& files);
  const RobotConfig& config() const noexcept { return config_; }
  // State thread: sum of the buses' EEPROM generations, and the published areas.
  uint64_t eeprom_generation() noexcept;
  RobotEeprom published_eeprom();
  // While the bus threads are stopped: the EEPROM areas now.
  RobotEeprom eeprom_now() const;
  std::vector<std::vector<uint16_t>> model_numbers() const;
  // The levels thread: once every bus published a new sensor-levels sample since the last
  // message, fills `out` (cleared first) with every bus' newest one and returns true. Not rt-safe (protobuf allocates).
  bool sensor_levels(levels::SensorLevels& out);
  // Every bus' servo table (robot fields left to the caller). Any thread but the bus threads.
  std::vector<contract::BusTable> servo_tables();
  std::size_t bus_count() const noexcept { return buses_.size(); }
  BusRuntime& bus(std::size_t index) noexcept { return *buses_[index]; }
  const BusRuntime& bus(std::size_t index) const noexcept { return *buses_[index]; }

 private:
  RobotConfig config_;
  std::size_t index_;
  std::unique_ptr<body::SimulatedBody> body_;  // before the buses, which refer to it
  std::string state_path_;  // its EEPROM state file, "" without a state directory
  bool state_loaded_;       // the devices' EEPROM came from state_path_
  std::vector<std::unique_ptr<BusRuntime>> buses_;
  uint64_t levels_sequence_ = 0;     // levels thread
  std::vector<bool> levels_fresh_;  // levels thread: bus b has a sample not yet sent
};

}  // namespace doppel::gateway
