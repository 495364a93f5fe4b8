#pragma once
// The client side of camera streaming, for vision code, tools and tests: connect to the RouDi on
// this machine, list the cameras that publish, and hold frames in shared memory without a copy.
// A Frame releases its chunk when destroyed; hold few at a time (the publisher's pools are finite,
// and a client that hoards frames makes the publisher drop frames for every subscriber).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "camera/camera_info.h"
#include "camera/frame.h"

namespace doppel::camera {

// True when a RouDi (iox-roudi or a doppel) runs on this machine. Setup code.
bool roudi_running();

// Registers this process with the running RouDi as `app_name`-<pid>, first removing what killed
// clients of that name left behind (remove_stale_client_files). iceoryx's own log lines are shown
// only if `verbose`. Does nothing when this process already has iceoryx (a roudi::Host, or an
// earlier call). Throws std::runtime_error when no RouDi runs (iceoryx itself would wait a minute
// and then abort).
void connect_client(const std::string& app_name, bool verbose = false);

// iceoryx leaves a socket `directory`/`app_name`-<pid> and its .lock behind when a client is
// killed. Removes each pair whose process is gone, whose lock nobody holds and that belongs to this
// user; returns the number of files removed.
int remove_stale_client_files(const std::string& app_name, const std::string& directory);

// Cameras whose info topic can be found within `timeout_s`. Requires connect_client() or a host.
std::vector<CameraInfo> list_cameras(double timeout_s = 1.0);

// Changes the noise filters of camera `camera` in the process that publishes it (a running doppel)
// through its settings topic, and waits until the camera confirms. Returns the camera's CameraInfo
// as confirmed: `noise` in use and `noise_from_sequence`, the first frame rendered with it.
// Requires connect_client() or a host. Throws std::invalid_argument for out-of-range values (the
// message names the field and its range), std::runtime_error when the camera is not published or
// does not confirm within `timeout_s` (its camera thread renders no frames). Setup code.
CameraInfo set_camera_noise(const std::string& camera, const NoiseConfig& noise, double timeout_s = 3.0);

class FrameSubscriber;

// A frame held in shared memory. Move-only; the chunk goes back to the publisher's pool on
// destruction or release().
class Frame {
 public:
  Frame(Frame&& other) noexcept;
  Frame& operator=(Frame&& other) noexcept;
  Frame(const Frame&) = delete;
  Frame& operator=(const Frame&) = delete;
  ~Frame();

  const FrameHeader& header() const noexcept { return *header_; }
  const uint8_t* pixels() const noexcept { return frame_pixels(header_); }
  // Null when the camera sends no annotations.
  const FrameAnnotations* annotations() const noexcept { return frame_annotations(header_); }
  void release() noexcept;

 private:
  friend class FrameSubscriber;
  Frame(std::shared_ptr<void> port, const FrameHeader* header) noexcept;
  std::shared_ptr<void> port_;  // the subscriber port that must release the chunk
  const FrameHeader* header_ = nullptr;
};

struct SubscriberOptions {
  uint32_t queue_capacity = 2;  // frames waiting; older ones are discarded for this subscriber only
  bool latest_on_connect = false;  // also receive the last frame published before subscribing
};

struct SubscriberStats {
  uint64_t received = 0;   // frames taken
  uint64_t missed = 0;     // sequence gaps seen (dropped by the publisher or overwritten in the queue)
  uint64_t invalid = 0;    // chunks that failed frame_valid() and were released unread
};

class FrameSubscriber {
 public:
  // Subscribes to camera `camera`. Requires connect_client() or a StreamingHost in this process.
  explicit FrameSubscriber(const std::string& camera, const SubscriberOptions& options = {});
  ~FrameSubscriber();
  FrameSubscriber(const FrameSubscriber&) = delete;
  FrameSubscriber& operator=(const FrameSubscriber&) = delete;

  // Busy-polling: the next queued frame, or nothing. Never blocks.
  std::optional<Frame> try_take() noexcept;
  // Sleeps on an iceoryx WaitSet until a frame arrives or `timeout_s` passes.
  std::optional<Frame> wait_take(double timeout_s) noexcept;
  // True once the publisher is connected (subscription acknowledged).
  bool connected() const noexcept;
  SubscriberStats stats() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace doppel::camera
