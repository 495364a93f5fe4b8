#include "truth/truth_service.h"

#include <pthread.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "roudi/host.h"

namespace doppel::truth {

TruthService::TruthService(TruthOptions options)
    : options_(std::move(options)),
      samples_(std::make_unique<concurrency::SpscQueue<WorldSample, 1024>>()),
      bindings_in_(std::make_unique<concurrency::SpscQueue<BindingChange, 16>>()) {
  if (options_.transport.iceoryx) {
    roudi::HostOptions host;
    host.verbose = options_.verbose;
    roudi_ = roudi::Host::share(host);
  }
  transport_ = std::make_unique<Transport>(options_.transport);
}

TruthService::~TruthService() {
  stop();
  transport_.reset();  // its iceoryx ports before the host
  roudi_.reset();
}

std::string TruthService::add_robot(std::size_t robot, const RobotBinding& binding,
                                    const contract::WorldModelSettings& settings) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (std::string problem = topic_.set(robot, settings); !problem.empty()) return problem;
    transport_->add_robot(robot);
    update_enabled();
  }
  BindingChange change{robot, true, binding.in_world, binding.team, binding.has_camera, binding.camera_body, {}};
  Eigen::Map<Eigen::Matrix4d>(change.X_BC.data()) = binding.X_BC.matrix();
  push_change(change);
  return "";
}

void TruthService::push_change(const BindingChange& change) {
  // The simulation thread takes changes every step; a full queue empties within milliseconds.
  std::lock_guard<std::mutex> lock(binding_mutex_);
  while (!bindings_in_->try_push(change)) std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

void TruthService::remove_robot(std::size_t robot) {
  BindingChange change;
  change.robot = robot;
  push_change(change);
  std::lock_guard<std::mutex> lock(mutex_);
  topic_.remove(robot);
  transport_->remove_robot(robot);
  update_enabled();
}

std::optional<contract::WorldModelSettings> TruthService::settings(std::size_t robot) {
  std::lock_guard<std::mutex> lock(mutex_);
  const contract::WorldModelSettings* s = topic_.settings(robot);
  return s != nullptr ? std::optional(*s) : std::nullopt;
}

std::string TruthService::set_settings(std::size_t robot, const contract::WorldModelSettings& settings) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (topic_.settings(robot) == nullptr) return "robot " + std::to_string(robot) + " has no world-model sensor";
  std::string problem = topic_.set(robot, settings);
  update_enabled();
  return problem;
}

void TruthService::update_enabled() { any_enabled_.store(topic_.any_enabled(), std::memory_order_release); }

void TruthService::add_poller(Poller poll) {
  std::lock_guard<std::mutex> lock(mutex_);
  pollers_.push_back(std::move(poll));
}

void TruthService::capture(const physics::World& world, int64_t sim_time_ns) noexcept {
  BindingChange change;
  while (bindings_in_->try_pop(change)) {
    if (change.robot >= kMaxRobots) continue;
    if (!change.bound) {
      bindings_[change.robot].reset();
      continue;
    }
    RobotBinding& b = bindings_[change.robot].emplace();
    b.in_world = change.in_world;
    b.team = change.team;
    b.has_camera = change.has_camera;
    b.camera_body = change.camera_body;
    b.X_BC.matrix() = Eigen::Map<const Eigen::Matrix4d>(change.X_BC.data());
  }
  if (!any_enabled_.load(std::memory_order_acquire)) return;
  WorldSample sample;
  sample.sim_time_ns = sim_time_ns;
  for (std::size_t r = 0; r < kMaxRobots; ++r) {
    if (!bindings_[r] || bindings_[r]->in_world >= world.robot_count()) continue;
    const RobotBinding& b = *bindings_[r];
    RobotSample& s = sample.robots[r];
    const Eigen::Isometry3d X_WR = world.robot_pose(b.in_world);
    s.present = true;
    s.team = b.team;
    s.x_m = X_WR.translation().x();
    s.y_m = X_WR.translation().y();
    s.yaw_rad = std::atan2(X_WR.linear()(1, 0), X_WR.linear()(0, 0));
    s.view_x_m = s.x_m;
    s.view_y_m = s.y_m;
    s.view_yaw_rad = s.yaw_rad;
    if (b.has_camera) {
      const Eigen::Isometry3d X_WC = world.body_pose(b.in_world, b.camera_body) * b.X_BC;
      const Eigen::Vector3d axis = X_WC.linear().col(2);  // camera frame: z along the optical axis
      if (std::hypot(axis.x(), axis.y()) > 1e-6) {  // a camera looking straight down has no direction
        s.view_x_m = X_WC.translation().x();
        s.view_y_m = X_WC.translation().y();
        s.view_yaw_rad = std::atan2(axis.y(), axis.x());
      }
    }
  }
  sample.ball_count = static_cast<uint32_t>(std::min(world.ball_count(), kMaxBalls));
  for (std::size_t b = 0; b < sample.ball_count; ++b) {
    const Eigen::Vector3d p = world.ball_position(b);
    sample.balls[b] = {p.x(), p.y(), p.z()};
  }
  samples_->try_push(sample);  // full: dropped and counted; this thread never waits
}

void TruthService::start() {
  if (thread_.joinable()) return;
  running_ = true;
  thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "doppel-truth");
    run();
  });
}

void TruthService::stop() {
  running_ = false;
  if (thread_.joinable()) thread_.join();
}

void TruthService::run() noexcept {
  WorldSample sample;
  std::string bytes;
  while (running_.load(std::memory_order_relaxed)) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (samples_->try_pop(sample)) {
        ++samples_taken_;
        try {
          topic_.on_sample(sample, [&](std::size_t robot, const proto::truth::WorldModel& message) {
            ++messages_;
            message.SerializeToString(&bytes);
            transport_->send(robot, kWorldModelTopic, bytes);
          });
        } catch (const std::exception&) {
          // Only allocation can fail here; the next sample tries again.
        }
      }
      for (Poller& poll : pollers_) poll(*transport_);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

TruthStats TruthService::stats() {
  std::lock_guard<std::mutex> lock(mutex_);
  return {samples_taken_, samples_->dropped(), messages_, transport_->stats()};
}

std::string TruthService::describe() const {
  std::ostringstream out;
  out << "doppel: world model on";
  if (options_.transport.iceoryx) out << " iceoryx (" << kServiceId << ", robot<N>, " << kWorldModelTopic << ")";
  if (options_.transport.iceoryx && options_.transport.udp) out << " and";
  if (options_.transport.udp) {
    out << " UDP " << options_.transport.udp_address << ":" << options_.transport.udp_base_port << "+N";
  }
  out << " (doppel-truth)\n";
  return out.str();
}

}  // namespace doppel::truth
