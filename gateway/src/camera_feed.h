#pragma once
// The robots' cameras inside doppel: every camera mount of a simulated robot's description streams
// through iceoryx (camera/). The simulation thread offers a copy of the scene at the cameras' frame
// period and never waits: it takes the hand-over lock only if it is free (try_lock) and otherwise
// offers again next step. A camera thread renders and publishes at the cameras' rates of simulation
// time; rendering never runs on the simulation thread.

#include <Eigen/Geometry>
#include <atomic>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "camera/camera_config.h"
#include "camera/streaming.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "physics/scene_view.h"
#include "physics/world.h"

namespace doppel::gateway {

class CameraFeed {
 public:
  // One stream per camera of every simulated robot: `cameras[w]` are the cameras of robot w of the
  // world, named as they will be published. Starts or attaches to RouDi.
  // Setup; throws std::runtime_error when streaming cannot start.
  CameraFeed(const physics::World& world, const std::vector<std::vector<CameraSetup>>& cameras,
             const Options& options);
  ~CameraFeed();

  bool empty() const noexcept { return mounts_.empty(); }

  // Simulation thread, after every step: hands over the scene when a frame is due. rt-safe
  // (try_lock, and fill_scene reuses the same storage after the first call).
  void offer(const physics::World& world) noexcept;

  void start();
  void stop();

  std::string describe() const;
  std::string summary() const;

 private:
  struct Mount {
    std::size_t robot = 0;                                  // robot index in the world
    std::size_t body = 0;                                   // body the camera is mounted on
    camera::CameraConfig config;                            // resolution, lens, X_BC
    std::unique_ptr<camera::CameraStream> stream;           // its iceoryx publisher
    double next_frame_s = 0.0;                              // simulation time of its next frame
  };
  void run();

  std::unique_ptr<camera::StreamingHost> host_;
  std::vector<Mount> mounts_;
  int64_t offer_period_ns_ = 50'000'000;  // the fastest camera's frame period
  int64_t next_offer_ns_ = 0;             // simulation thread only

  std::mutex handover_;                    // guards the four members below
  physics::SceneView offered_scene_;
  std::vector<Eigen::Isometry3d> offered_X_WB_;  // per mount: pose of its body
  double offered_time_s_ = 0.0;
  bool fresh_ = false;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace doppel::gateway
