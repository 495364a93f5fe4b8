#include "robot_runtime.h"

#include <pthread.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <future>
#include <numbers>
#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <variant>

#include "dynamixel/device_factory.h"
#include "dynamixel/models.h"
#include "dynamixel/protocol2_factory.h"
#include "dynamixel/protocol2_models.h"
#include "dynamixel/servo_controller.h"
#include "gateway/gateway.h"

namespace doppel::gateway {
namespace {

uint8_t default_return_delay_raw(const dynamixel::ModelSpec& spec) {
  const dynamixel::RegisterSpec* rdt = dynamixel::find_register(spec.registers, dynamixel::p1::kReturnDelayTime);
  return static_cast<uint8_t>(rdt != nullptr ? rdt->default_raw : 250);
}

double no_load_speed_rad_s(const dynamixel::ServoSpec& servo, double supply_voltage_v) {
  // A DC motor's no-load speed grows with its supply voltage.
  return servo.motor->no_load_speed_rpm * 2.0 * std::numbers::pi / 60.0 * supply_voltage_v /
         servo.motor->rated_voltage_v;
}

// The EEPROM items of `saved` (restored from a state file) whose value differs from `from_file`
// (the same device as the robot file alone makes it), by e-Manual name, e.g. "ID 1 -> 5, Baud Rate
// 3 (1000000 bps) -> 1 (57600 bps)"; "" when none does. A device without a register list (Bit-Bots
// boards) is compared byte by byte.
std::string eeprom_differences(const dynamixel::Device& saved, const dynamixel::Device& from_file) {
  const std::span<const uint8_t> now = saved.eeprom();
  const std::span<const uint8_t> file = from_file.eeprom();
  std::ostringstream out;
  const auto value = [](std::span<const uint8_t> bytes, uint32_t address, uint8_t size, bool is_signed) {
    uint32_t raw = 0;
    for (uint8_t i = 0; i < size; ++i) raw |= static_cast<uint32_t>(bytes[address + i]) << (8 * i);
    if (is_signed && size < 4 && (raw & (1u << (8 * size - 1))) != 0) raw |= ~0u << (8 * size);
    return is_signed ? static_cast<int64_t>(static_cast<int32_t>(raw)) : static_cast<int64_t>(raw);
  };
  const auto item = [&](std::string_view name, uint32_t address, uint8_t size, bool is_signed) {
    if (address + size > now.size() || address + size > file.size()) return;
    const int64_t was = value(file, address, size, is_signed);
    const int64_t is = value(now, address, size, is_signed);
    if (was == is) return;
    out << (out.tellp() > 0 ? ", " : "") << name << " " << was;
    if (name == "Baud Rate") out << " (" << from_file.baud_bps() << " bps)";
    out << " -> " << is;
    if (name == "Baud Rate") out << " (" << saved.baud_bps() << " bps)";
  };
  const auto* p1 = dynamic_cast<const dynamixel::Protocol1Device*>(&saved);
  const auto* p2 = dynamic_cast<const dynamixel::Protocol2Device*>(&saved);
  if (p1 != nullptr) {
    for (const dynamixel::RegisterSpec& r : p1->spec().registers) {
      if (r.area == dynamixel::Area::kEeprom) item(r.name, r.address, r.size, r.is_signed);
    }
  } else if (p2 != nullptr && !p2->spec().registers.empty()) {
    for (const dynamixel::P2RegisterSpec& r : p2->spec().registers) {
      if (r.area == dynamixel::Area::kEeprom) item(r.name, r.address, r.size, r.is_signed);
    }
  } else {
    for (std::size_t a = 0; a < std::min(now.size(), file.size()); ++a) {
      item("EEPROM byte " + std::to_string(a), static_cast<uint32_t>(a), 1, false);
    }
  }
  return out.str();
}

const char* protocol_name(dynamixel::Protocol protocol) {
  return protocol == dynamixel::Protocol::kV1 ? "Protocol 1.0" : "Protocol 2.0";
}

}  // namespace

BusRuntime::BusRuntime(const BusConfig& config, std::size_t bus_index, body::SimulatedBody& body,
                       const std::string& link, const Options& options,
                       const std::vector<std::vector<uint8_t>>* saved, const std::string& state_path)
    : config_(config), bus_index_(bus_index), body_(body) {
  for (std::size_t d = 0; d < config.devices.size(); ++d) {
    const DeviceConfig& device = config.devices[d];
    const auto build = [&] {
      if (device.firmware == dynamixel::Protocol::kV2) {
        return dynamixel::make_protocol2_device(device.model, device.id, config.baud_bps,
                                                device.return_delay_raw.value_or(250));
      }
      const dynamixel::ModelSpec& spec = dynamixel::model_spec(device.model);
      return dynamixel::make_protocol1_device(device.model, device.id, config.baud_bps,
                                              device.return_delay_raw.value_or(default_return_delay_raw(spec)));
    };
    dynamixel::BuiltDevice built = build();
    const std::string who = "bus " + std::to_string(bus_index) + " device " + std::to_string(d) + " (" +
                            device.model + " " + device.name + ")";
    std::string changes;  // with saved EEPROM: how it differs from what the robot file alone gives
    if (saved != nullptr) {
      dynamixel::BuiltDevice from_file = build();
      for (const InitialValue& initial : device.initial) {
        if (initial.eeprom) (void)from_file.device->write_item(initial.address, initial.value);
      }
      if (const std::string error = built.device->restore_eeprom(saved->at(d)); !error.empty()) {
        throw std::runtime_error("state file " + state_path + ": " + who + ": " + error +
                                 " (--fresh starts from the robot file and overwrites it)");
      }
      changes = eeprom_differences(*built.device, *from_file.device);
    }
    for (const InitialValue& initial : device.initial) {
      if (!initial.eeprom) {
        initial_ram_.push_back({d, initial.address, initial.value});
      }
      if (saved != nullptr && initial.eeprom) {
        continue;  // the saved EEPROM holds what the driver made of it
      }
      if (const std::string error = built.device->write_item(initial.address, initial.value); !error.empty()) {
        throw std::invalid_argument(initial.location + ": " + who + ": initial " + initial.item + ": " + error);
      }
    }
    if (built.device->eeprom().size() > kMaxEepromBytes) {
      throw std::invalid_argument(who + " has a larger EEPROM than Doppel keeps");
    }
    eeprom_changes_.push_back(std::move(changes));
    every_device_.push_back(Gated{d, dynamic_cast<dynamixel::Protocol1Device*>(built.device.get()),
                                  dynamic_cast<dynamixel::Protocol2Device*>(built.device.get())});
    link_to_body(built.role, device, d);
    bus_devices_.add(*built.device);
    devices_.push_back(std::move(built.device));
  }
  if (servos_.size() > kMaxServos || imus_.size() > kMaxBoards || feet_.size() > kMaxBoards) {
    throw std::invalid_argument("bus '" + config.name + "' has more devices than Doppel supports");
  }
  wire_supply_switch();
  stuck_.resize(servos_.size());
  if (options.truth.sensor_levels_hz > 0.0) {
    static_assert(kMaxServos <= body::kLevelsMaxServos && kMaxBoards <= body::kLevelsMaxBoards);
    levels_period_ns_ = std::max<int64_t>(1, std::llround(1e9 / options.truth.sensor_levels_hz));
    for (const auto& device : devices_) levels_tables_.push_back(body::device_table(*device));
    auto layout = [&](std::size_t d) {
      const DeviceConfig& device = config.devices[d];
      return body::levels_device(static_cast<uint32_t>(bus_index), devices_[d]->id(), device.name, device.model,
                                 device.firmware, *devices_[d]);
    };
    for (const auto& servo : servos_) levels_layout_.servos.push_back(layout(servo.device_index));
    for (const auto& imu : imus_) levels_layout_.imus.push_back(layout(imu.device_index));
    for (const auto& foot : feet_) levels_layout_.feet.push_back(layout(foot.device_index));
    levels_ = std::make_unique<concurrency::Snapshot<body::BusLevelsSample>>();
  }
  // The servo table's columns: each servo's registers found by their e-Manual names.
  for (const auto& servo : servos_) {
    const Gated& device = every_device_[servo.device_index];
    auto address = [&](std::initializer_list<std::string_view> names) -> int32_t {
      for (std::string_view name : names) {
        if (device.p1 != nullptr) {
          for (const dynamixel::RegisterSpec& r : device.p1->spec().registers) {
            if (r.name == name) return r.address;
          }
        }
        if (device.p2 != nullptr) {
          for (const dynamixel::P2RegisterSpec& r : device.p2->spec().registers) {
            if (r.name == name) return r.address;
          }
        }
      }
      return -1;
    };
    ServoColumns columns{servo.device_index, {}};
    columns.address[kTorque] = address({"Torque Enable"});
    columns.address[kGoal] = address({"Goal Position"});
    columns.address[kPresent] = address({"Present Position"});
    columns.address[kSpeed] = address({"Present Speed", "Present Velocity"});
    columns.address[kLoad] = address({"Present Load", "Present Current"});
    columns.address[kTemperature] = address({"Present Temperature"});
    columns.address[kVoltage] = address({"Present Voltage", "Present Input Voltage"});
    columns.address[kError] = address({"Hardware Error Status"});
    servo_columns_.push_back(columns);
  }

  bus::BusServerOptions server_options;
  server_options.timing_mode = options.buses.timing;
  server_options.processing_ns = static_cast<int64_t>(options.buses.processing_us * 1000.0);
  server_options.adapter_latency_ms = config.latency_timer_ms.value_or(options.buses.latency_timer_ms);
  server_options.adapter = config.adapter;
  if (!options.record.path.empty()) {
    tap_ = std::make_unique<bus::TrafficTap>();
    server_options.tap = tap_.get();
  }
  port_ = std::make_unique<bus::PtyPort>(link, bus::LinkTiming::kOnPublish);  // start() publishes it
  server_ = std::make_unique<bus::BusServer>(*port_, bus_devices_, server_options, this);
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    const std::span<const uint8_t> bytes = devices_[d]->eeprom();
    std::copy(bytes.begin(), bytes.end(), eeprom_seen_.bytes[d].begin());
  }
  eeprom_.publish(eeprom_seen_);
  publish_servo_table();
}

void BusRuntime::publish_eeprom_changes() noexcept {
  bool changed = false;
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    const std::span<const uint8_t> bytes = devices_[d]->eeprom();
    if (!std::equal(bytes.begin(), bytes.end(), eeprom_seen_.bytes[d].begin())) {
      std::copy(bytes.begin(), bytes.end(), eeprom_seen_.bytes[d].begin());
      changed = true;
    }
  }
  if (changed) {
    ++eeprom_seen_.generation;
    eeprom_.publish(eeprom_seen_);
  }
}

std::vector<std::vector<uint8_t>> BusRuntime::eeprom_bytes(const BusEeprom& eeprom) const {
  std::vector<std::vector<uint8_t>> out;
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    const std::size_t n = devices_[d]->eeprom().size();
    out.emplace_back(eeprom.bytes[d].begin(), eeprom.bytes[d].begin() + static_cast<std::ptrdiff_t>(n));
  }
  return out;
}

std::vector<std::vector<uint8_t>> BusRuntime::eeprom_now() const {
  std::vector<std::vector<uint8_t>> out;
  for (const auto& device : devices_) {
    const std::span<const uint8_t> bytes = device->eeprom();
    out.emplace_back(bytes.begin(), bytes.end());
  }
  return out;
}

std::vector<uint16_t> BusRuntime::model_numbers() const {
  std::vector<uint16_t> out;
  for (const auto& device : devices_) out.push_back(device->model_number());
  return out;
}

void BusRuntime::link_to_body(const dynamixel::DeviceRole& role, const DeviceConfig& device,
                              std::size_t device_index) {
  const auto bus = static_cast<uint32_t>(bus_index_);
  struct Linker {
    BusRuntime& self;
    const DeviceConfig& device;
    uint32_t bus;
    std::size_t index;
    void operator()(dynamixel::SimulatedServo* servo) const {
      const dynamixel::ServoSpec& spec = device.firmware == dynamixel::Protocol::kV2
                                             ? dynamixel::p2_model_spec(device.model).servo
                                             : dynamixel::model_spec(device.model).servo;
      body::ServoSetup setup{dynamixel::servo_controller_config(device.model),
                             no_load_speed_rad_s(spec, self.config_.supply_voltage_v), self.config_.supply_voltage_v};
      self.servos_.push_back({servo, self.body_.add_servo(bus, device.id, setup), index});
    }
    void operator()(dynamixel::SimulatedImu* imu) const {
      self.imus_.push_back({imu, self.body_.add_imu(bus, device.id), index});
    }
    void operator()(dynamixel::SimulatedFootBoard* foot) const {
      self.feet_.push_back({foot, self.body_.add_foot(bus, device.id), index});
    }
    void operator()(dynamixel::SimulatedPowerBoard* power) const { self.power_boards_.push_back(power); }
    // A sub-controller is the bus's IMU and a power board at once (its buttons are not driven yet).
    void operator()(dynamixel::SimulatedController* controller) const {
      (*this)(static_cast<dynamixel::SimulatedImu*>(controller));
      (*this)(static_cast<dynamixel::SimulatedPowerBoard*>(controller));
    }
  };
  std::visit(Linker{*this, device, bus, device_index}, role);
}

void BusRuntime::wire_supply_switch() {
  for (const auto& device : devices_) {
    const auto* cm730 = dynamic_cast<const dynamixel::Cm730*>(device.get());
    if (cm730 == nullptr) continue;
    if (supply_switch_ != nullptr) {
      throw std::invalid_argument("bus '" + config_.name + "' has two CM-730 sub-controllers; one switches its supply");
    }
    supply_switch_ = cm730;
  }
  if (supply_switch_ == nullptr) return;
  supply_on_ = supply_switch_->dxl_power_on();
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    dynamixel::Device* device = devices_[d].get();
    if (device == supply_switch_) continue;
    Gated gated{d, dynamic_cast<dynamixel::Protocol1Device*>(device), dynamic_cast<dynamixel::Protocol2Device*>(device)};
    if (gated.p1 == nullptr && gated.p2 == nullptr) {
      throw std::invalid_argument("bus '" + config_.name + "': " + config_.devices[d].model + " " +
                                  config_.devices[d].name + " cannot be powered by the CM-730's Dynamixel Power");
    }
    gated_.push_back(gated);
    bus_devices_.set_powered(d, supply_on_);
  }
}

void BusRuntime::follow_supply_switch() noexcept {
  if (supply_switch_ == nullptr || supply_switch_->dxl_power_on() == supply_on_) {
    return;
  }
  supply_on_ = !supply_on_;
  for (const Gated& gated : gated_) {
    if (supply_on_) {
      if (gated.p1 != nullptr) gated.p1->power_cycle();
      if (gated.p2 != nullptr) gated.p2->power_cycle();
    }
    bus_devices_.set_powered(gated.device_index, supply_on_);
  }
}

BusRuntime::~BusRuntime() { join(); }

void BusRuntime::start(const std::atomic<bool>& stop, int rt_priority) {
  std::promise<void> serving;  // its shared state outlives whichever side lets go first
  std::future<void> served = serving.get_future();
  thread_ = std::thread([this, &stop, serving = std::move(serving), rt_priority]() mutable {
    pthread_setname_np(pthread_self(), "doppel-bus");
    if (rt_priority > 0) {
      sched_param param{};
      param.sched_priority = rt_priority;
      if (int error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); error != 0) {
        std::fprintf(stderr, "doppel: %s: SCHED_FIFO priority %d refused (%s); normal scheduling\n",
                     port_->link_path().c_str(), rt_priority, std::strerror(error));
      }
    }
    serving.set_value();
    server_->run(stop);
  });
  // The link appears only once this thread serves the port: a driver that opens it the moment it
  // exists is answered at once (bytes it writes before the thread's first poll wait in the pty).
  served.wait();
  publish_link();
}

void BusRuntime::publish_link() { port_->publish_link(); }

void BusRuntime::join() {
  if (thread_.joinable()) {
    thread_.join();
  }
}

void BusRuntime::before_dispatch() noexcept {
  const uint64_t requested = power_on_requested_.load(std::memory_order_acquire);
  if (requested != power_on_done_.load(std::memory_order_relaxed) && power_on_pending_ != requested) {
    power_on_pending_ = requested;
    for (const Gated& device : every_device_) {
      if (device.p1 != nullptr) device.p1->power_cycle();
      if (device.p2 != nullptr) device.p2->power_cycle();
    }
    for (const RamValue& ram : initial_ram_) {
      (void)devices_[ram.device_index]->write_item(ram.address, ram.value);  // checked at start-up
    }
    supply_on_ = supply_switch_ == nullptr || supply_switch_->dxl_power_on();
    for (const Gated& gated : gated_) bus_devices_.set_powered(gated.device_index, supply_on_);
  }
  // The simulation publishes at 1 kHz; between two of its steps the registers are already current
  // (unless the faults changed: they act on the newest measurements at once).
  const bool new_faults = bus_faults_.update();
  const bool new_feedback = feedback_.update();
  if (!new_feedback && !new_faults) {
    return;
  }
  const BusFeedback& feedback = feedback_.latest();
  const faults::FaultTable& table = bus_faults_.latest();
  const int64_t t = feedback.power.sim_time_ns;
  bus_sim_now_ns_ = t;
  const auto bus = static_cast<uint32_t>(bus_index_);
  for (std::size_t d = 0; d < devices_.size(); ++d) {
    bus_devices_.set_reachable(d, !faults::unreachable(table, bus, config_.devices[d].id, t));
  }
  for (std::size_t i = 0; i < servos_.size(); ++i) {
    dynamixel::ServoFeedback measured = feedback.servos[i];
    faults::apply_servo(table, bus, config_.devices[servos_[i].device_index].id, t, measured, stuck_[i]);
    servos_[i].device->apply(measured);
  }
  for (std::size_t i = 0; i < imus_.size(); ++i) {
    dynamixel::ImuFeedback measured = feedback.imus[i];
    if (faults::apply_imu(table, bus, config_.devices[imus_[i].device_index].id, t, measured)) {
      imus_[i].device->apply(measured);
    }
  }
  for (std::size_t i = 0; i < feet_.size(); ++i) {
    dynamixel::FootFeedback measured = feedback.feet[i];
    if (faults::apply_foot(table, bus, config_.devices[feet_[i].device_index].id, t, measured)) {
      feet_[i].device->apply(measured);
    }
  }
  dynamixel::PowerFeedback power = feedback.power;
  faults::apply_power(table, t, power);
  for (dynamixel::SimulatedPowerBoard* board : power_boards_) board->apply(power);
  if (levels_ != nullptr && new_feedback) sample_sensor_levels(feedback);
}

std::span<const dynamixel::OutgoingStatus> BusRuntime::impair(const dynamixel::InstructionPacket& packet,
                                                              std::span<const dynamixel::OutgoingStatus> statuses) noexcept {
  const std::span<const dynamixel::OutgoingStatus> out =
      wire_faults_->apply(bus_faults_.latest(), static_cast<uint32_t>(bus_index_), bus_sim_now_ns_, packet, statuses);
  const faults::WireCounters& c = wire_faults_->counters();
  wire_counters_.corrupted.store(c.corrupted, std::memory_order_relaxed);
  wire_counters_.dropped.store(c.dropped, std::memory_order_relaxed);
  wire_counters_.delayed.store(c.delayed, std::memory_order_relaxed);
  wire_counters_.stray.store(c.stray, std::memory_order_relaxed);
  return out;
}

void BusRuntime::sample_sensor_levels(const BusFeedback& feedback) noexcept {
  const int64_t t = feedback.power.sim_time_ns;
  if (levels_sequence_ != 0 && t >= levels_last_ns_ && t < levels_next_ns_) return;  // not due (a reset goes back)
  body::BusLevelsSample& sample = levels_->back();
  sample.sequence = ++levels_sequence_;
  sample.sim_time_ns = t;
  for (std::size_t i = 0; i < servos_.size(); ++i) {
    const std::size_t d = servos_[i].device_index;
    body::copy_table(levels_tables_[d], bus_devices_.powered(d), sample.servo_tables[i]);
    sample.servo_truth[i] = feedback.servos[i];
  }
  for (std::size_t i = 0; i < imus_.size(); ++i) {
    const std::size_t d = imus_[i].device_index;
    body::copy_table(levels_tables_[d], bus_devices_.powered(d), sample.imu_tables[i]);
    sample.imu_truth[i] = feedback.imus[i];
  }
  for (std::size_t i = 0; i < feet_.size(); ++i) {
    const std::size_t d = feet_[i].device_index;
    body::copy_table(levels_tables_[d], bus_devices_.powered(d), sample.foot_tables[i]);
    sample.foot_truth[i] = feedback.feet[i];
  }
  levels_->publish();
  levels_last_ns_ = t;
  const int64_t slot = t >= 0 ? t / levels_period_ns_ : -1;
  levels_next_ns_ = (slot + 1) * levels_period_ns_;
}

void BusRuntime::after_dispatch() noexcept {
  follow_supply_switch();
  BusCommands& commands = commands_.back();
  for (std::size_t i = 0; i < servos_.size(); ++i) {
    commands.servos[i] = servos_[i].device->command();
    if (!bus_devices_.powered(servos_[i].device_index)) {
      commands.servos[i].torque_enabled = false;  // no supply, no torque
    }
  }
  commands_.publish();
  publish_eeprom_changes();
  collisions_.store(bus_devices_.counters().collisions, std::memory_order_relaxed);  // for servo_table()
  if (power_on_pending_ != 0) {
    power_on_done_.store(power_on_pending_, std::memory_order_release);  // the new commands are out
    power_on_pending_ = 0;
  }
}

void BusRuntime::on_tick() noexcept {
  before_dispatch();
  after_dispatch();
  if (++servo_table_ticks_ >= kServoTableEveryTicks) {
    servo_table_ticks_ = 0;
    publish_servo_table();
  }
}

void BusRuntime::publish_servo_table() noexcept {
  BusServoTable& table = servo_table_.back();
  for (std::size_t i = 0; i < servo_columns_.size(); ++i) {
    const ServoColumns& columns = servo_columns_[i];
    const Gated& device = every_device_[columns.device_index];
    auto value = [&](Column column) -> int64_t {
      const int32_t address = columns.address[column];
      if (address < 0) return -1;
      if (device.p2 != nullptr) return device.p2->register_value(static_cast<uint16_t>(address));
      return device.p1->register_raw(static_cast<uint8_t>(address));
    };
    ServoRegisters& row = table.servos[i];
    row.id = devices_[columns.device_index]->id();
    row.torque = value(kTorque) > 0;
    row.goal_position = value(kGoal);
    row.present_position = value(kPresent);
    row.present_speed = value(kSpeed);
    row.present_load = value(kLoad);
    row.temperature = value(kTemperature);
    row.voltage = value(kVoltage);
    row.error = value(kError);
  }
  servo_table_.publish();
}

contract::BusTable BusRuntime::servo_table() {
  BusServoTable table;
  {
    std::lock_guard<std::mutex> lock(servo_table_mutex_);
    servo_table_.read(table);
  }
  contract::BusTable out;
  out.bus = bus_index_;
  out.link = port_->link_path();
  const bus::BusDiagnostics d = server_->diagnostics();  // lock-free
  out.counters = {d.packets, d.bad_checksums, d.replies, collisions_.load(std::memory_order_relaxed), d.dropped_replies,
                  d.timeouts, d.late_deliveries, d.max_lateness_ns, d.bytes_in, d.bytes_out, d.connected};
  for (std::size_t i = 0; i < servo_columns_.size(); ++i) {
    const ServoRegisters& r = table.servos[i];
    const DeviceConfig& device = config_.devices[servo_columns_[i].device_index];
    contract::ServoRow row;
    row.id = r.id;
    row.name = device.name;
    row.model = device.model;
    row.torque = r.torque;
    row.goal_position = r.goal_position;
    row.present_position = r.present_position;
    row.present_speed = r.present_speed;
    row.present_load = r.present_load;
    row.temperature = r.temperature;
    row.voltage = r.voltage;
    row.error = r.error;
    out.servos.push_back(std::move(row));
  }
  return out;
}

void BusRuntime::drive(double dt_s) noexcept {
  if (power_on_requested_.load(std::memory_order_acquire) != power_on_done_.load(std::memory_order_acquire)) {
    return;  // the commands are those from before a reset's power-on
  }
  const BusCommands& commands = commands_.latest();
  const faults::FaultTable& table = sim_faults_.latest();
  for (std::size_t i = 0; i < servos_.size(); ++i) {
    dynamixel::ServoCommand command = commands.servos[i];
    const double scale = faults::torque_scale(table, static_cast<uint32_t>(bus_index_),
                                              config_.devices[servos_[i].device_index].id, sim_now_ns_,
                                              config_.supply_voltage_v);
    command.torque_limit_ratio *= scale;  // a weak motor, a sagging supply: less torque at the horn
    body_.drive(servos_[i].body_index, command, dt_s);
  }
}

void BusRuntime::sense(int64_t sim_time_ns, double servo_current_a) noexcept {
  sim_now_ns_ = sim_time_ns;
  BusFeedback& feedback = feedback_.back();
  for (std::size_t i = 0; i < servos_.size(); ++i) feedback.servos[i] = body_.servo(servos_[i].body_index, sim_time_ns);
  for (std::size_t i = 0; i < imus_.size(); ++i) feedback.imus[i] = body_.imu(imus_[i].body_index, sim_time_ns);
  for (std::size_t i = 0; i < feet_.size(); ++i) feedback.feet[i] = body_.foot(feet_[i].body_index, sim_time_ns);
  feedback.power = dynamixel::PowerFeedback{config_.supply_voltage_v, servo_current_a, sim_time_ns};
  feedback_.publish();
}

std::string_view BusRuntime::device_role(int32_t id) const noexcept {
  for (std::size_t d = 0; d < config_.devices.size(); ++d) {
    if (config_.devices[d].id != id) continue;
    for (const auto& servo : servos_) {
      if (servo.device_index == d) return "servo";
    }
    for (const auto& imu : imus_) {
      if (imu.device_index == d) return "imu";
    }
    for (const auto& foot : feet_) {
      if (foot.device_index == d) return "foot";
    }
    return "board";
  }
  return "";
}

std::string BusRuntime::describe() const {
  std::ostringstream out;
  out << "  " << port_->link_path() << " -> " << port_->slave_path() << "   bus '" << config_.name << "', "
      << protocol_name(config_.protocol) << ", " << config_.baud_bps << " bps";
  if (config_.adapter == bus::AdapterProfile::kUsb2ax) out << ", USB2AX adapter (answers ID 253 and SYNC READ 0x84)";
  if (config_.latency_timer_ms) out << ", FTDI latency timer " << *config_.latency_timer_ms << " ms";
  out << "\n";
  if (supply_switch_ != nullptr) {
    out << "     Dynamixel Power (24) of the CM-730 switches the other devices' supply: while it is 0 they\n"
        << "     neither answer nor hold (the DARwIn-OP framework's Connect() writes 1)\n";
  }
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const DeviceConfig& device = config_.devices[i];
    const bool other_protocol = devices_[i]->protocol() != config_.protocol;
    char line[160];
    std::snprintf(line, sizeof(line), "     ID %3u %-14s %s%s\n", devices_[i]->id(), device.model.c_str(),
                  device.name.c_str(), other_protocol ? "  (speaks the other protocol)" : "");
    out << line;
    if (!eeprom_changes_[i].empty()) {
      out << "            EEPROM from the state file, not the robot file: " << eeprom_changes_[i] << "\n";
    }
    if (!dynamixel::baud_rates_match(devices_[i]->baud_bps(), config_.baud_bps)) {
      out << "            ! listens at " << devices_[i]->baud_bps() << " bps, the bus runs at " << config_.baud_bps
          << " bps: it hears nothing sent at the bus' rate (as a real servo would not)\n";
    }
  }
  return out.str();
}

std::string BusRuntime::summary() const {
  const bus::BusDiagnostics d = server_->diagnostics();
  const dynamixel::BusDeviceCounters& devices = bus_devices_.counters();
  std::ostringstream out;
  out << "  " << port_->link_path() << ": " << d.connects << " client sessions, " << d.bytes_in << " bytes in, "
      << d.bytes_out << " bytes out\n"
      << "    packets " << d.packets << " (bad checksum " << d.bad_checksums << ", not understood at the line's baud rate "
      << devices.baud_mismatches << "), garbage bytes skipped " << d.dropped_bytes << ", inter-byte timeouts "
      << d.timeouts << "\n"
      << "    replies " << d.replies << " (collisions " << devices.collisions << ", broken bulk-read chains "
      << devices.broken_chains << "), dropped for a full schedule " << d.dropped_replies
      << ", bytes discarded after a client left " << d.discarded_bytes << "\n"
      << "    late deliveries " << d.late_deliveries << " (worst " << static_cast<double>(d.max_lateness_ns) / 1000.0
      << " us late); delivery time minus due time: p50 <= " << bus::lateness_quantile_ns(d, 0.5) / 1000
      << " us, p99 <= " << bus::lateness_quantile_ns(d, 0.99) / 1000 << " us, p99.9 <= "
      << bus::lateness_quantile_ns(d, 0.999) / 1000 << " us\n";
  const faults::WireCounters wire = wire_fault_counters();
  if (wire.corrupted + wire.dropped + wire.delayed + wire.stray > 0) {
    out << "    faults on the wire (docs/faults.md): statuses corrupted " << wire.corrupted << ", dropped " << wire.dropped
        << ", late " << wire.delayed << ", stray " << wire.stray << "\n";
  }
  return out.str();
}

RobotRuntime::RobotRuntime(const RobotConfig& config, std::size_t robot_index,
                           std::unique_ptr<body::SimulatedBody> body, const Options& options,
                           const RobotEeprom* saved, const std::string& state_path)
    : config_(config), index_(robot_index), body_(std::move(body)), state_path_(state_path), state_loaded_(saved != nullptr) {
  for (std::size_t b = 0; b < config.buses.size(); ++b) {
    buses_.push_back(std::make_unique<BusRuntime>(config.buses[b], b, *body_,
                                                  link_path(options.buses.link_dir, robot_index, b), options,
                                                  saved != nullptr ? &saved->at(b) : nullptr, state_path));
  }
  // Power-on (before the world's first step): the sensors' first sample and the servos' Present
  // registers exist before any packet.
  sense(0);
  for (auto& bus : buses_) {
    bus->before_dispatch();
  }
}

void RobotRuntime::add_latency_timer_files(bus::LatencyTimerFiles& files) {
  for (auto& bus : buses_) {
    files.add(bus::LatencyTimerFiles::path_for_link(bus->link()), bus->server());
  }
}

void RobotRuntime::start(const std::atomic<bool>& stop, int rt_priority) {
  for (auto& bus : buses_) {
    bus->start(stop, rt_priority);
  }
}

void RobotRuntime::publish_links() {
  for (auto& bus : buses_) {
    bus->publish_link();
  }
}

void RobotRuntime::join() {
  for (auto& bus : buses_) {
    bus->join();
  }
}

void RobotRuntime::drive(double dt_s) noexcept {
  for (auto& bus : buses_) {
    bus->drive(dt_s);
  }
}

void RobotRuntime::sense(int64_t sim_time_ns) noexcept {
  // A power board measures what every servo of the robot draws, on all its buses (docs/devices.md).
  const double servo_current_a = body_->servo_supply_current_a();
  for (auto& bus : buses_) {
    bus->sense(sim_time_ns, servo_current_a);
  }
}

void RobotRuntime::power_on() noexcept {
  body_->reset();
  for (auto& bus : buses_) bus->request_power_on();
}

uint64_t RobotRuntime::eeprom_generation() noexcept {
  uint64_t generation = 0;
  for (auto& bus : buses_) generation += bus->published_eeprom().generation;
  return generation;
}

RobotEeprom RobotRuntime::published_eeprom() {
  RobotEeprom out;
  for (auto& bus : buses_) out.push_back(bus->eeprom_bytes(bus->published_eeprom()));
  return out;
}

RobotEeprom RobotRuntime::eeprom_now() const {
  RobotEeprom out;
  for (const auto& bus : buses_) out.push_back(bus->eeprom_now());
  return out;
}

std::vector<std::vector<uint16_t>> RobotRuntime::model_numbers() const {
  std::vector<std::vector<uint16_t>> out;
  for (const auto& bus : buses_) out.push_back(bus->model_numbers());
  return out;
}

bool RobotRuntime::sensor_levels(levels::SensorLevels& out) {
  // One message per sample period: once every bus has a new sample (the buses sample the same grid
  // of simulation time, each on its own thread).
  levels_fresh_.resize(buses_.size(), false);
  bool enabled = false, all_fresh = true;
  for (std::size_t b = 0; b < buses_.size(); ++b) {
    if (!buses_[b]->sensor_levels_enabled()) continue;
    enabled = true;
    if (buses_[b]->update_sensor_levels()) levels_fresh_[b] = true;
    all_fresh = all_fresh && levels_fresh_[b];
  }
  if (!enabled || !all_fresh) return false;
  std::fill(levels_fresh_.begin(), levels_fresh_.end(), false);
  out.Clear();
  out.set_robot(static_cast<uint32_t>(index_));
  out.set_robot_name(config_.name);
  out.set_sequence(++levels_sequence_);
  for (auto& bus : buses_) {
    if (bus->sensor_levels_enabled() && bus->sensor_levels().sequence != 0) {
      body::append_bus_levels(bus->sensor_levels_layout(), bus->sensor_levels(), out);
    }
  }
  return true;
}

std::vector<contract::BusTable> RobotRuntime::servo_tables() {
  std::vector<contract::BusTable> out;
  for (auto& bus : buses_) out.push_back(bus->servo_table());
  return out;
}

std::string RobotRuntime::describe() const {
  std::ostringstream out;
  out << "doppel: robot " << index_ << " '" << config_.name << "' (" << config_.source << "), " << body_->description()
      << "\n";
  if (state_loaded_) {
    std::size_t differing = 0;
    for (const auto& bus : buses_) differing += bus->devices_differing_from_file();
    out << "  EEPROM state loaded from " << state_path_ << " (what drivers wrote to EEPROM in earlier runs; --fresh "
        << "starts from the robot file): "
        << (differing == 0 ? std::string("every device as in the robot file")
                           : std::to_string(differing) + (differing == 1 ? " device differs" : " devices differ") +
                                 " from the robot file")
        << "\n";
  } else if (!state_path_.empty()) {
    out << "  EEPROM state from the robot file; what drivers write to EEPROM is kept in " << state_path_ << "\n";
  }
  for (const auto& bus : buses_) {
    out << bus->describe();
  }
  return out.str();
}

std::string RobotRuntime::summary() const {
  std::ostringstream out;
  for (const auto& bus : buses_) {
    out << bus->summary();
  }
  return out.str();
}

}  // namespace doppel::gateway
