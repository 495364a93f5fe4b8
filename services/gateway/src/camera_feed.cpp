#include "camera_feed.h"

#include <pthread.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "camera/lens.h"
#include "camera/noise.h"
#include "camera/pixel_format.h"
#include "lockstep/futex.h"
#include "physics/field.h"

namespace doppel::gateway {

namespace {

camera::StreamingOptions streaming_options(const Options& options) {
  camera::StreamingOptions streaming;
  streaming.roudi = options.cameras.external_roudi ? camera::RouDiMode::kExternal : camera::RouDiMode::kAuto;
  streaming.verbose = options.cameras.verbose;
  return streaming;
}

}  // namespace

// Every hand-over slot sized now, so that offer() never allocates: room for the poses of cameras
// added later, and the world's scene (without a world, the static field and the ball).
CameraFeed::OfferedScene CameraFeed::initial_scene(const physics::World* world) {
  OfferedScene initial;
  initial.X_WB.assign(kMaxMounts, Eigen::Isometry3d::Identity());
  if (world != nullptr) {
    world->fill_scene(initial.scene);
  } else {
    initial.scene.shapes = physics::field_shapes();
    initial.scene.shapes.push_back(physics::ball_shape(Eigen::Vector3d(0.0, 0.0, 0.5 * physics::FieldSpec{}.ball_diameter_m)));
  }
  return initial;
}

CameraFeed::CameraFeed(const physics::World* world, const std::vector<std::vector<CameraSetup>>& robot_cameras,
                       const std::vector<WorldCameraSetup>& world_cameras, const Options& options) {
  std::vector<camera::CameraConfig> configs;
  std::set<std::string> names;
  auto add = [&](Mount mount, const std::string& where) {
    if (!names.insert(mount.config.name).second) {
      throw std::invalid_argument(where + ": camera name '" + mount.config.name +
                                  "' is already used by another camera of this run");
    }
    configs.push_back(mount.config);
    mounts_.push_back(std::move(mount));
  };
  const std::size_t robots = world != nullptr ? world->robot_count() : 0;
  for (std::size_t r = 0; r < robot_cameras.size() && r < robots; ++r) {
    for (const CameraSetup& setup : robot_cameras[r]) {
      Mount mount;
      mount.robot = r;
      mount.body = setup.body;
      mount.config = setup.config;
      add(std::move(mount), "robot camera");
    }
  }
  for (const WorldCameraSetup& setup : world_cameras) {
    Mount mount;
    mount.fixed = true;
    mount.config = setup.config;
    add(std::move(mount), setup.location);
  }
  names_ = names;
  if (mounts_.size() > kMaxMounts) {
    throw std::invalid_argument("cameras: at most " + std::to_string(kMaxMounts) + " in one run");
  }
  for (std::size_t i = 0; i < mounts_.size(); ++i) {
    offered_[i] = Offered{true, mounts_[i].fixed, mounts_[i].robot, mounts_[i].body};
  }
  offered_end_ = mounts_.size();
  if (mounts_.empty()) {
    return;
  }
  host_ = std::make_unique<camera::StreamingHost>(configs, streaming_options(options));
  double fastest_fps = 0.0;
  for (Mount& mount : mounts_) {
    mount.stream = std::make_unique<camera::CameraStream>(*host_, mount.config);
    fastest_fps = std::max(fastest_fps, mount.config.fps);
  }
  offer_period_ns_ = 1e9 / fastest_fps;
  handover_ = std::make_unique<concurrency::Snapshot<OfferedScene>>(initial_scene(world));
}

CameraFeed::~CameraFeed() {
  stop();
  for (Mount& mount : mounts_) {
    mount.stream.reset();  // every stream goes before the host
  }
}

void CameraFeed::offer(const physics::World* world, int64_t sim_time_ns) noexcept {
  if (handover_ == nullptr || offered_end_ == 0 || sim_time_ns < next_offer_ns_) {
    return;
  }
  OfferedScene& offered = handover_->back();
  if (world != nullptr) {
    world->fill_scene(offered.scene);  // after a robot was added, each slot grows once
    for (std::size_t i = 0; i < offered_end_; ++i) {
      if (offered_[i].active && !offered_[i].fixed) {
        offered.X_WB[i] = world->body_pose(offered_[i].robot, offered_[i].body);
      }
    }
  }
  offered.scene.sim_time_s = static_cast<double>(sim_time_ns) * 1e-9;
  const uint32_t offer = offers_.load(std::memory_order_relaxed) + 1;
  offered.offer = offer;
  handover_->publish();
  offers_.store(offer, std::memory_order_release);
  lockstep::futex_wake_all(offers_);
  // The next grid time after this one: no drift from steps that land late on the grid.
  const double k = std::floor(static_cast<double>(sim_time_ns) / offer_period_ns_ + 1e-9) + 1.0;
  next_offer_ns_ = std::llround(k * offer_period_ns_);
}

void CameraFeed::wait_rendered() const noexcept {
  const uint32_t offered = offers_.load(std::memory_order_acquire);
  for (;;) {
    const uint32_t rendered = rendered_.load(std::memory_order_acquire);
    if (static_cast<int32_t>(offered - rendered) <= 0 || !running_.load(std::memory_order_acquire)) return;
    lockstep::futex_wait(rendered_, rendered, 10'000'000);
  }
}

void CameraFeed::start() {
  wanted_ = true;
  if (handover_ == nullptr || running_.exchange(true)) {
    return;
  }
  thread_ = std::thread([this] {
    pthread_setname_np(pthread_self(), "doppel-camera");
    run();
  });
}

void CameraFeed::stop() {
  running_ = false;
  if (thread_.joinable()) {
    thread_.join();
  }
}

void CameraFeed::run() {
  while (running_.load(std::memory_order_relaxed)) {
    const uint32_t seen = offers_.load(std::memory_order_acquire);
    if (!handover_->update()) {
      lockstep::futex_wait(offers_, seen, 1'000'000);  // woken by offer(); 1 ms to notice stop()
      continue;
    }
    // The reader's slot: the simulation thread does not touch it until the next update().
    const OfferedScene& offered = handover_->latest();
    const double time_s = offered.scene.sim_time_s;
    std::lock_guard<std::mutex> lock(mounts_mutex_);  // held by the adding thread only to add or remove a camera
    for (std::size_t i = 0; i < mounts_.size(); ++i) {
      Mount& mount = mounts_[i];
      if (!mount.used || !mount.shown || mount.stream == nullptr || time_s <= mount.from_s ||
          time_s + 1e-9 < mount.next_frame_s) {
        continue;
      }
      mount.stream->render_and_publish(offered.scene, camera::camera_pose_W(mount.config.mount, offered.X_WB[i]), time_s);
      // Its next frame is due at the next k / fps (offers land on the first step at or after it).
      mount.next_frame_s = (std::floor(time_s * mount.config.fps + 1e-6) + 1.0) / mount.config.fps;
    }
    rendered_.store(offered.offer, std::memory_order_release);
    lockstep::futex_wake_all(rendered_);
  }
}

std::string CameraFeed::describe() const {
  std::ostringstream out;
  if (host_ != nullptr) {
    out << "doppel: " << host_->description() << "\n";
  }
  std::lock_guard<std::mutex> lock(mounts_mutex_);
  for (const Mount& mount : mounts_) {
    if (!mount.used || mount.stream == nullptr) continue;
    const camera::CameraConfig& c = mount.config;
    out << "  camera '" << c.name << "' ";
    if (mount.fixed) {
      const Eigen::Vector3d p = c.mount.X_WC.translation();
      out << "fixed in the field at (" << p.x() << ", " << p.y() << ", " << p.z() << ") m";
    } else {
      out << "on body '" << c.mount.body << "'";
    }
    out << ": " << c.width_px << "x" << c.height_px << " " << camera::to_string(c.format) << " at " << c.fps
        << " fps, " << camera::to_string(c.lens.model) << " lens, noise " << camera::describe(c.noise)
        << " (doppel-camera list / save / stats / noise)\n";
  }
  return out.str();
}

std::string CameraFeed::summary() const {
  std::ostringstream out;
  std::lock_guard<std::mutex> lock(mounts_mutex_);
  for (const Mount& mount : mounts_) {
    if (!mount.used || mount.stream == nullptr) continue;
    const auto stats = mount.stream->stats();
    out << "  camera '" << mount.config.name << "': " << stats.published << " frames published, " << stats.dropped
        << " dropped, " << stats.skipped_idle << " skipped with no subscriber, " << stats.settings_applied
        << " settings changes applied, " << stats.settings_rejected << " refused\n";
  }
  return out.str();
}

std::size_t CameraFeed::add(const CameraSetup& setup, const Options& options) {
  std::size_t id = 0;
  {
    std::lock_guard<std::mutex> lock(mounts_mutex_);
    if (!names_.insert(setup.config.name).second) {
      throw std::invalid_argument("camera name '" + setup.config.name + "' is already used by another camera of this run");
    }
    while (id < mounts_.size() && mounts_[id].used) ++id;
    if (id >= kMaxMounts) {
      names_.erase(setup.config.name);
      throw std::runtime_error("at most " + std::to_string(kMaxMounts) + " cameras in one run");
    }
    if (id == mounts_.size()) mounts_.emplace_back();
    mounts_[id] = Mount{};
    mounts_[id].shown = false;
    mounts_[id].config = setup.config;
  }
  try {
    if (host_ == nullptr) {  // nothing streamed yet: iceoryx starts now, its pools sized for this camera
      host_ = std::make_unique<camera::StreamingHost>(std::vector<camera::CameraConfig>{setup.config},
                                                      streaming_options(options));
    }
    auto stream = std::make_unique<camera::CameraStream>(*host_, setup.config);  // outside the lock: it builds its renderer
    std::lock_guard<std::mutex> lock(mounts_mutex_);
    Mount& mount = mounts_[id];
    mount.body = setup.body;
    mount.stream = std::move(stream);
  } catch (...) {
    release(id);
    throw;
  }
  return id;
}

void CameraFeed::attach(std::size_t id, std::size_t robot, std::size_t body, double fps, const physics::World* world) {
  if (handover_ == nullptr) {
    handover_ = std::make_unique<concurrency::Snapshot<OfferedScene>>(initial_scene(world));
    offer_period_ns_ = 1e9 / fps;
  }
  offer_period_ns_ = std::min(offer_period_ns_, 1e9 / fps);
  offered_[id] = Offered{true, false, robot, body};
  offered_end_ = std::max(offered_end_, id + 1);
}

void CameraFeed::show(std::size_t id, double from_sim_s) {
  {
    std::lock_guard<std::mutex> lock(mounts_mutex_);
    mounts_[id].shown = true;
    mounts_[id].from_s = from_sim_s;
    mounts_[id].next_frame_s = 0.0;
  }
  if (wanted_ && handover_ != nullptr && !running_.exchange(true)) {
    thread_ = std::thread([this] {
      pthread_setname_np(pthread_self(), "doppel-camera");
      run();
    });
  }
}

void CameraFeed::hide(std::size_t id) {
  std::lock_guard<std::mutex> lock(mounts_mutex_);
  mounts_[id].shown = false;
  mounts_[id].stream.reset();  // its publisher and services go
}

void CameraFeed::detach(std::size_t id) noexcept { offered_[id].active = false; }

void CameraFeed::release(std::size_t id) {
  std::lock_guard<std::mutex> lock(mounts_mutex_);
  names_.erase(mounts_[id].config.name);
  mounts_[id] = Mount{};
  mounts_[id].used = false;
}

}  // namespace doppel::gateway
