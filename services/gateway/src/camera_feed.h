#pragma once
// The cameras inside doppel: every camera mount of a simulated robot's description (a linked
// viewpoint that moves with its body) and every camera of the session file (fixed in the field)
// streams through iceoryx (camera/). The simulation thread writes the scene at the cameras' frame
// period into a triple buffer (concurrency::Snapshot) and never waits or locks; the camera thread
// renders the newest complete scene in place and publishes at the cameras' rates of simulation
// time, skipping scenes it was too slow for. Rendering never runs on the simulation thread. Between
// frames the camera thread takes settings sent over iceoryx (doppel-camera noise); nothing on either
// thread allocates per frame.
//
// Cameras of a robot added while doppel runs (docs/robots-at-run-time.md) join in three steps: the
// adding thread creates their streams (add(), which may start iceoryx when nothing streamed yet),
// the simulation thread starts offering their bodies' poses (attach(), between two ticks), the
// adding thread lets the camera thread render them (show()). They leave in the other order:
// hide() (the stream is gone: its iceoryx services disappear), detach(), release().

#include <Eigen/Geometry>
#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <set>
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

  // Most cameras at once: every robot's (SimController's limit) and the session's.
  static constexpr std::size_t kMaxMounts = 64;
  // Adding thread: a stream for camera `setup` of a robot; returns its mount id.
  // Throws std::invalid_argument (a name already in use, a bad setting) and std::runtime_error
  // (iceoryx cannot start, the frame does not fit its pools, too many cameras).
  std::size_t add(const CameraSetup& setup, const Options& options);
  // Simulation thread, between two ticks: offers mount `id`'s body pose from now on. Allocates
  // (the hand-over slots, the first time anything streams). rt-unsafe, like every add.
  void attach(std::size_t id, std::size_t robot, std::size_t body, double fps, const physics::World* world);
  // Adding thread: the camera thread renders mount `id` in scenes taken after `from_sim_s` and
  // runs if it did not yet (after start()).
  void show(std::size_t id, double from_sim_s);
  // Removing thread: the camera thread stops rendering mount `id`; its stream goes.
  void hide(std::size_t id);
  // Simulation thread: stops offering mount `id`.
  void detach(std::size_t id) noexcept;
  // Removing thread, after detach(): the id and its name are free again.
  void release(std::size_t id);

  // Simulation thread, after every step (`world` as given to the constructor, `sim_time_ns` its
  // time): hands over the scene when a frame is due. Frames are due on a fixed grid of simulation
  // time, k / fps of the fastest camera; a scene is offered at the first step at or after each
  // grid time. rt-safe: lock-free, wait-free (one futex wake for the camera thread), and it fills
  // a hand-over slot sized in the constructor, so it allocates nothing.
  void offer(const physics::World* world, int64_t sim_time_ns) noexcept;
  // Simulation thread under lockstep (docs/lockstep.md, "Cameras"), after offer(): blocks (wall
  // time, on a futex) until the camera thread has rendered and published every frame due in the
  // scenes offered so far, so that a frame is in its subscribers' queues before any controller
  // thread sees its simulation time. Returns at once when the camera thread does not run. No lock,
  // no allocation.
  void wait_rendered() const noexcept;

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
    double next_frame_s = 0.0;                              // simulation time of its next frame (k / fps)
    bool used = true;                                       // false: a free id
    bool shown = true;                                      // the camera thread renders it
    double from_s = -1.0;                                   // only in scenes taken after this time
  };
  // What the simulation thread knows of a mount (its own copy: mounts_ belongs to the camera side).
  struct Offered {
    bool active = false;
    bool fixed = false;
    std::size_t robot = 0;
    std::size_t body = 0;
  };
  // What the simulation thread hands to the camera thread: one per frame period.
  struct OfferedScene {
    physics::SceneView scene;              // without a world: the static field, filled once
    std::vector<Eigen::Isometry3d> X_WB;   // per mount: pose of its body (identity when fixed)
    uint32_t offer = 0;                    // offers_ when it was offered
  };
  static OfferedScene initial_scene(const physics::World* world);
  void run();

  std::unique_ptr<camera::StreamingHost> host_;
  // Camera side: every mount by id (an id whose stream is null is free), under mounts_mutex_ once
  // the camera thread runs; the adding thread changes them under it too.
  mutable std::mutex mounts_mutex_;
  std::vector<Mount> mounts_;
  std::set<std::string> names_;  // of every mount in use, under mounts_mutex_
  std::atomic<bool> wanted_{false};  // start() was called (the thread starts with the first camera)
  // Simulation side.
  std::array<Offered, kMaxMounts> offered_{};
  std::size_t offered_end_ = 0;           // ids below this may be active
  double offer_period_ns_ = 50'000'000.0;  // the fastest camera's frame period
  int64_t next_offer_ns_ = 0;              // simulation thread only: the next grid time
  // Futex words: scenes offered (simulation thread) and the last offer the camera thread finished.
  std::atomic<uint32_t> offers_{0};
  std::atomic<uint32_t> rendered_{0};

  // Simulation thread writes, camera thread reads; every slot sized in the constructor. Null
  // without cameras.
  std::unique_ptr<concurrency::Snapshot<OfferedScene>> handover_;

  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace doppel::gateway
