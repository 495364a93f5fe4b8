#pragma once
// The cameras inside doppel: every camera mount of a simulated robot's description (a linked
// viewpoint that moves with its body) and every camera of the session file (fixed in the field)
// streams through iceoryx (camera/). The simulation thread writes the scene at the cameras' frame
// period into a triple buffer (concurrency::Snapshot) and never waits or locks; the camera thread
// renders the newest complete scene in place and publishes at the cameras' rates of simulation
// time, skipping scenes it was too slow for. Rendering never runs on the simulation thread. Between
// frames the camera thread takes settings sent over iceoryx (doppel-camera noise); nothing on either
// thread allocates per frame.

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "camera/camera_config.h"
#include "camera/streaming.h"
#include "concurrency/snapshot.h"
#include "gateway/options.h"
#include "gateway/robot_config.h"
#include "physics/scene_view.h"
#include "physics/world.h"

namespace doppel::gateway {

class CameraFeed {
 public:
  // One stream per camera: `robot_cameras[w]` are the cameras of robot w of `world`, named as they
  // will be published, and `world_cameras` are fixed in the field. Without a world (`world` null:
  // no simulated body) the cameras see the field alone, with the ball on the centre spot. Starts or
  // attaches to RouDi. Setup; throws std::invalid_argument when two cameras share a name and
  // std::runtime_error when streaming cannot start.
  CameraFeed(const physics::World* world, const std::vector<std::vector<CameraSetup>>& robot_cameras,
             const std::vector<WorldCameraSetup>& world_cameras, const Options& options);
  ~CameraFeed();

  bool empty() const noexcept { return mounts_.empty(); }

  // Simulation thread, after every step (`world` as given to the constructor, `sim_time_ns` its
  // time): hands over the scene when a frame is due. rt-safe: lock-free, wait-free, and it fills
  // a hand-over slot sized in the constructor, so it allocates nothing.
  void offer(const physics::World* world, int64_t sim_time_ns) noexcept;

  void start();
  void stop();

  std::string describe() const;
  std::string summary() const;

 private:
  struct Mount {
    bool fixed = false;                                     // fixed in the field (session camera)
    std::size_t robot = 0;                                  // robot index in the world (robot camera)
    std::size_t body = 0;                                   // body the camera is mounted on (robot camera)
    camera::CameraConfig config;                            // resolution, lens, noise, X_BC or X_WC
    std::unique_ptr<camera::CameraStream> stream;           // its iceoryx publisher
    double next_frame_s = 0.0;                              // simulation time of its next frame
  };
  // What the simulation thread hands to the camera thread: one per frame period.
  struct OfferedScene {
    physics::SceneView scene;              // without a world: the static field, filled once
    std::vector<Eigen::Isometry3d> X_WB;   // per mount: pose of its body (identity when fixed)
  };
  void run();

  std::unique_ptr<camera::StreamingHost> host_;
  std::vector<Mount> mounts_;
  int64_t offer_period_ns_ = 50'000'000;  // the fastest camera's frame period
  int64_t next_offer_ns_ = 0;             // simulation thread only

  // Simulation thread writes, camera thread reads; every slot sized in the constructor. Null
  // without cameras.
  std::unique_ptr<concurrency::Snapshot<OfferedScene>> handover_;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace doppel::gateway
