#include "robot_runtime.h"

#include <pthread.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <sstream>

#include "dynamixel/device_factory.h"
#include "dynamixel/protocol2_factory.h"
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

const char* protocol_name(dynamixel::Protocol protocol) {
  return protocol == dynamixel::Protocol::kV1 ? "Protocol 1.0" : "Protocol 2.0";
}

}  // namespace

BusRuntime::BusRuntime(const BusConfig& config, std::size_t bus_index, BodyRef body, const std::string& link,
                       const Options& options)
    : config_(config), bus_index_(bus_index), body_(body) {
  const auto bus = static_cast<uint32_t>(bus_index);
  for (const DeviceConfig& device : config.devices) {
    if (config.protocol == dynamixel::Protocol::kV2) {
      devices_.push_back(dynamixel::make_protocol2_device(device.model, device.id, config.baud_bps,
                                                          device.return_delay_raw.value_or(250)));
    } else {
      const dynamixel::ModelSpec& spec = dynamixel::model_spec(device.model);
      devices_.push_back(dynamixel::make_protocol1_device(
          device.model, device.id, config.baud_bps, device.return_delay_raw.value_or(default_return_delay_raw(spec))));
    }
    dynamixel::Device* created = devices_.back().get();
    std::optional<physics::ImuHandle> imu_handle;
    std::optional<physics::FootHandle> foot_handle;
    if (body_.world != nullptr) {
      imu_handle = body_.world->find_imu(body_.robot, bus, device.id);
      foot_handle = body_.world->find_foot(body_.robot, bus, device.id);
    }
    if (auto* servo = dynamic_cast<dynamixel::SimulatedServo*>(created)) {
      const dynamixel::ServoSpec& spec = config.protocol == dynamixel::Protocol::kV2
                                             ? dynamixel::p2_model_spec(device.model).servo
                                             : dynamixel::model_spec(device.model).servo;
      add_servo(*servo, spec, device.model, device.id);
    } else if (auto* imu = dynamic_cast<dynamixel::SimulatedImu*>(created)) {
      imus_.push_back({imu, imu_handle});
    } else if (auto* foot = dynamic_cast<dynamixel::SimulatedFootBoard*>(created)) {
      feet_.push_back({foot, foot_handle});
    } else if (auto* core = dynamic_cast<dynamixel::BitbotsCore*>(created)) {
      cores_.push_back(core);
    }
    bus_devices_.add(*created);
  }
  if (servos_.size() > kMaxServos || imus_.size() > kMaxBoards || feet_.size() > kMaxBoards) {
    throw std::invalid_argument("bus '" + config.name + "' has more devices than Doppel supports");
  }

  bus::BusServerOptions server_options;
  server_options.timing_mode = options.timing;
  server_options.processing_ns = static_cast<int64_t>(options.processing_us * 1000.0);
  server_options.adapter_latency_ms = options.latency_timer_ms;
  port_ = std::make_unique<bus::PtyPort>(link);
  server_ = std::make_unique<bus::BusServer>(*port_, bus_devices_, server_options, this);
}

void BusRuntime::add_servo(dynamixel::SimulatedServo& servo, const dynamixel::ServoSpec& spec,
                           const std::string& model, uint8_t id) {
  ServoSlot& slot = servos_.emplace_back(servo, dynamixel::servo_controller_config(model),
                                         no_load_speed_rad_s(spec, config_.supply_voltage_v));
  if (body_.world != nullptr) {
    slot.motor = body_.world->find_motor(body_.robot, static_cast<uint32_t>(bus_index_), id);
  }
}

BusRuntime::~BusRuntime() { join(); }

void BusRuntime::start(const std::atomic<bool>& stop, int rt_priority) {
  thread_ = std::thread([this, &stop, rt_priority] {
    pthread_setname_np(pthread_self(), "doppel-bus");
    if (rt_priority > 0) {
      sched_param param{};
      param.sched_priority = rt_priority;
      if (int error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); error != 0) {
        std::fprintf(stderr, "doppel: %s: SCHED_FIFO priority %d refused (%s); normal scheduling\n",
                     port_->link_path().c_str(), rt_priority, std::strerror(error));
      }
    }
    server_->run(stop);
  });
}

void BusRuntime::join() {
  if (thread_.joinable()) {
    thread_.join();
  }
}

void BusRuntime::before_dispatch() noexcept {
  // The simulation publishes at 1 kHz; between two of its steps the registers are already current.
  if (!feedback_.update()) {
    return;
  }
  const BusFeedback& feedback = feedback_.latest();
  for (std::size_t i = 0; i < servos_.size(); ++i) servos_[i].device->apply(feedback.servos[i]);
  for (std::size_t i = 0; i < imus_.size(); ++i) imus_[i].device->apply(feedback.imus[i]);
  for (std::size_t i = 0; i < feet_.size(); ++i) feet_[i].device->apply(feedback.feet[i]);
  for (dynamixel::BitbotsCore* core : cores_) {
    core->apply(config_.supply_voltage_v, 0.0);
  }
}

void BusRuntime::after_dispatch() noexcept {
  BusCommands& commands = commands_.back();
  for (std::size_t i = 0; i < servos_.size(); ++i) commands.servos[i] = servos_[i].device->command();
  commands_.publish();
}

void BusRuntime::on_tick() noexcept {
  before_dispatch();
  after_dispatch();
}

void BusRuntime::drive(double dt_s) noexcept {
  const BusCommands& commands = commands_.latest();
  for (std::size_t i = 0; i < servos_.size(); ++i) {
    ServoSlot& slot = servos_[i];
    const dynamixel::ServoCommand& command = commands.servos[i];
    if (!slot.motor) {
      slot.joint.step(command, dt_s);
      continue;
    }
    const dynamixel::ControllerOutput out =
        slot.controller.update(command, slot.position_rad, slot.velocity_rad_s, dt_s, config_.supply_voltage_v);
    body_.world->set_motor(*slot.motor, physics::MotorCommand{command.torque_enabled, out.pwm_ratio,
                                                              command.torque_limit_ratio});
    slot.overload = out.overload;
  }
}

void BusRuntime::sense(int64_t sim_time_ns, double kinematic_cell_force_n) noexcept {
  BusFeedback& feedback = feedback_.back();
  for (std::size_t i = 0; i < servos_.size(); ++i) {
    ServoSlot& slot = servos_[i];
    dynamixel::ServoFeedback& servo = feedback.servos[i];
    if (slot.motor) {
      const physics::MotorState state = body_.world->motor(*slot.motor);
      servo.position_rad = state.position_rad;
      servo.velocity_rad_s = state.velocity_rad_s;
      servo.torque_ratio = state.torque_ratio;
      servo.voltage_v = state.voltage_v;
      servo.temperature_c = state.temperature_c;
      servo.current_a = std::copysign(state.current_a, state.torque_nm);
    } else {
      servo.position_rad = slot.joint.position_rad();
      servo.velocity_rad_s = slot.joint.velocity_rad_s();
      servo.torque_ratio = 0.0;
      servo.current_a = 0.0;
      servo.voltage_v = config_.supply_voltage_v;
      servo.temperature_c = 25.0;
    }
    servo.overload = slot.overload;
    servo.sim_time_ns = sim_time_ns;
    slot.position_rad = servo.position_rad;
    slot.velocity_rad_s = servo.velocity_rad_s;
  }
  for (std::size_t i = 0; i < imus_.size(); ++i) {
    dynamixel::ImuFeedback& imu = feedback.imus[i];
    imu = dynamixel::ImuFeedback{};
    if (imus_[i].imu) {
      const physics::ImuState state = body_.world->imu(*imus_[i].imu);
      imu.roll_rad = state.roll_rad;
      imu.pitch_rad = state.pitch_rad;
      imu.yaw_rad = state.yaw_rad;
      imu.w_WS_S_rad_s = state.w_WS_S_rad_s;
      imu.a_WS_S_m_s2 = state.a_WS_S_m_s2;
    }
    imu.sim_time_ns = sim_time_ns;
  }
  for (std::size_t i = 0; i < feet_.size(); ++i) {
    dynamixel::FootFeedback& foot = feedback.feet[i];
    if (feet_[i].foot) {
      foot.force_n = body_.world->foot(*feet_[i].foot).force_n;
    } else {
      foot.force_n.fill(kinematic_cell_force_n);
    }
    foot.sim_time_ns = sim_time_ns;
  }
  feedback_.publish();
}

std::string BusRuntime::describe() const {
  std::ostringstream out;
  out << "  " << port_->link_path() << " -> " << port_->slave_path() << "   bus '" << config_.name << "', "
      << protocol_name(config_.protocol) << ", " << config_.baud_bps << " bps\n";
  for (std::size_t i = 0; i < devices_.size(); ++i) {
    const DeviceConfig& device = config_.devices[i];
    char line[128];
    std::snprintf(line, sizeof(line), "     ID %3u %-14s %s\n", device.id, device.model.c_str(), device.name.c_str());
    out << line;
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
  return out.str();
}

RobotRuntime::RobotRuntime(const RobotConfig& config, std::size_t robot_index, BodyRef body, const Options& options)
    : config_(config), index_(robot_index), body_(body) {
  for (std::size_t b = 0; b < config.buses.size(); ++b) {
    buses_.push_back(
        std::make_unique<BusRuntime>(config.buses[b], b, body, link_path(options.link_dir, robot_index, b), options));
    foot_boards_ += buses_.back()->foot_board_count();
  }
  // Power-on: the sensors' first sample and the servos' Present registers exist before any packet.
  sense(body.world != nullptr ? body.world->time_ns() : 0);
  for (auto& bus : buses_) {
    bus->before_dispatch();
  }
}

void RobotRuntime::start(const std::atomic<bool>& stop, int rt_priority) {
  for (auto& bus : buses_) {
    bus->start(stop, rt_priority);
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
  // Without a body, the weight of a robot standing still spreads evenly over its load cells.
  double cell_force_n = foot_boards_ == 0 ? 0.0
                                          : kKinematicRobotMassKg * kGravityM_S2 / (4.0 * static_cast<double>(foot_boards_));
  for (auto& bus : buses_) {
    bus->sense(sim_time_ns, cell_force_n);
  }
}

std::string RobotRuntime::describe() const {
  std::ostringstream out;
  out << "doppel: robot " << index_ << " '" << config_.name << "' (" << config_.source << "), "
      << (body_.world != nullptr ? "body simulated" : "no body: joints move kinematically") << "\n";
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
