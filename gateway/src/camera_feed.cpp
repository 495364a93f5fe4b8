#include "camera_feed.h"

#include <pthread.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "camera/lens.h"
#include "camera/pixel_format.h"

namespace doppel::gateway {

CameraFeed::CameraFeed(const physics::World& world, const std::vector<std::vector<CameraSetup>>& cameras,
                       const Options& options) {
  std::vector<camera::CameraConfig> configs;
  for (std::size_t r = 0; r < cameras.size() && r < world.robot_count(); ++r) {
    for (const CameraSetup& setup : cameras[r]) {
      Mount mount;
      mount.robot = r;
      mount.body = setup.body;
      mount.config = setup.config;
      configs.push_back(mount.config);
      mounts_.push_back(std::move(mount));
    }
  }
  if (mounts_.empty()) {
    return;
  }
  camera::StreamingOptions streaming;
  streaming.roudi = options.external_roudi ? camera::RouDiMode::kExternal : camera::RouDiMode::kAuto;
  host_ = std::make_unique<camera::StreamingHost>(configs, streaming);
  double fastest_fps = 0.0;
  for (Mount& mount : mounts_) {
    mount.stream = std::make_unique<camera::CameraStream>(*host_, mount.config);
    fastest_fps = std::max(fastest_fps, mount.config.fps);
  }
  offer_period_ns_ = static_cast<int64_t>(1e9 / fastest_fps);
  offered_X_WB_.resize(mounts_.size());
  // Size the hand-over scene now, so that offer() never allocates.
  world.fill_scene(offered_scene_);
}

CameraFeed::~CameraFeed() {
  stop();
  for (Mount& mount : mounts_) {
    mount.stream.reset();  // every stream goes before the host
  }
}

void CameraFeed::offer(const physics::World& world) noexcept {
  if (mounts_.empty() || world.time_ns() < next_offer_ns_) {
    return;
  }
  std::unique_lock lock(handover_, std::try_to_lock);
  if (!lock.owns_lock()) {
    return;  // the camera thread is copying: offer again next step
  }
  world.fill_scene(offered_scene_);
  for (std::size_t i = 0; i < mounts_.size(); ++i) {
    offered_X_WB_[i] = world.body_pose(mounts_[i].robot, mounts_[i].body);
  }
  offered_time_s_ = static_cast<double>(world.time_ns()) * 1e-9;
  fresh_ = true;
  next_offer_ns_ = world.time_ns() + offer_period_ns_;
}

void CameraFeed::start() {
  if (mounts_.empty() || running_.exchange(true)) {
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
  physics::SceneView scene;
  std::vector<Eigen::Isometry3d> X_WB(mounts_.size());
  while (running_.load(std::memory_order_relaxed)) {
    double time_s = 0.0;
    {
      std::lock_guard lock(handover_);
      if (fresh_) {
        scene.shapes = offered_scene_.shapes;
        scene.sim_time_s = offered_scene_.sim_time_s;
        X_WB = offered_X_WB_;
        time_s = offered_time_s_;
        fresh_ = false;
      }
    }
    if (time_s <= 0.0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    for (std::size_t i = 0; i < mounts_.size(); ++i) {
      Mount& mount = mounts_[i];
      if (time_s + 1e-9 < mount.next_frame_s) {
        continue;
      }
      mount.stream->render_and_publish(scene, camera::camera_pose_W(mount.config.mount, X_WB[i]), time_s);
      mount.next_frame_s = time_s + 1.0 / mount.config.fps;
    }
  }
}

std::string CameraFeed::describe() const {
  std::ostringstream out;
  if (host_ != nullptr) {
    out << "doppel: " << host_->description() << "\n";
  }
  for (const Mount& mount : mounts_) {
    out << "  camera '" << mount.config.name << "' on body '" << mount.config.mount.body << "': "
        << mount.config.width_px << "x" << mount.config.height_px << " " << camera::to_string(mount.config.format)
        << " at " << mount.config.fps << " fps, " << camera::to_string(mount.config.lens.model)
        << " lens (doppel-camera list / save / stats)\n";
  }
  return out.str();
}

std::string CameraFeed::summary() const {
  std::ostringstream out;
  for (const Mount& mount : mounts_) {
    const auto stats = mount.stream->stats();
    out << "  camera '" << mount.config.name << "': " << stats.published << " frames published, " << stats.dropped
        << " dropped, " << stats.skipped_idle << " skipped with no subscriber\n";
  }
  return out.str();
}

}  // namespace doppel::gateway
