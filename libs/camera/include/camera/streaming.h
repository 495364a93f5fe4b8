#pragma once
// Zero-copy frame publishing through iceoryx: each frame is rendered straight into a loaned
// shared-memory chunk and published; subscribers read the same memory. StreamingHost is the
// cameras' share of this process' iceoryx (roudi::Host, which the truth transport shares too): it
// sizes the in-process RouDi's pools from the cameras, or checks that a RouDi already running on the
// machine (an iox-roudi or another doppel) holds their frames, and says which. CameraStream is one
// camera's publisher. iceoryx types stay out of this header.
//
// Services: ("DoppelCamera", <camera name>, "frames") carries frames, ("DoppelCamera", <name>,
// "info") a CameraInfo with history 1 for discovery and the current settings, and ("DoppelCamera",
// <name>, "settings") takes NoiseRequests from other processes (doppel-camera noise), which the
// camera thread polls between frames.

#include <Eigen/Geometry>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "camera/camera_config.h"
#include "camera/camera_info.h"
#include "camera/frame.h"
#include "camera/noise.h"
#include "physics/scene_view.h"
#include "roudi/host.h"

namespace doppel::camera {

using RouDiMode = roudi::Mode;  // kAuto, kInProcess, kExternal (roudi/host.h)

struct StreamingOptions {
  RouDiMode roudi = RouDiMode::kAuto;  // see RouDiMode
  std::string runtime_name;            // iceoryx application name; empty = "doppel-<pid>"
  uint32_t chunks_per_camera = 32;     // frame chunks per camera in the in-process RouDi's pools
  double introspection_timeout_s = 3.0;  // external RouDi: how long to wait for its mempool report
  bool verbose = false;                // also print iceoryx's own warnings and info lines
};

class StreamingHost {
 public:
  // Brings up iceoryx for `cameras` (pools sized from them), or shares this process' roudi::Host
  // when one exists already (the truth transport's; its pools stay as they are). Throws
  // std::runtime_error with the reason (RouDi already running in kInProcess, none in kExternal, an
  // external RouDi's pools too small for a camera, /dev/shm too small) and std::logic_error when a
  // StreamingHost already exists in this process. Setup code.
  explicit StreamingHost(const std::vector<CameraConfig>& cameras, const StreamingOptions& options = {});
  ~StreamingHost();
  StreamingHost(const StreamingHost&) = delete;
  StreamingHost& operator=(const StreamingHost&) = delete;

  bool roudi_in_process() const noexcept;
  // One line for the log: which RouDi is used and, in-process, the pool sizes.
  const std::string& description() const noexcept;
  // Largest chunk payload of the pools in use (a frame needs frame_payload_bytes plus alignment).
  uint64_t max_payload_bytes() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

struct StreamStats {
  uint64_t published = 0;        // frames handed to iceoryx
  uint64_t dropped = 0;          // frames due but not delivered: no free chunk
  uint64_t skipped_idle = 0;     // frames not rendered because nobody subscribed
  uint64_t settings_applied = 0;   // noise changes taken over (set_noise() or a NoiseRequest)
  uint64_t settings_rejected = 0;  // NoiseRequests refused because a value was out of range
  double last_render_ms = 0.0;   // wall time of the last render
};

class CameraStream {
 public:
  // Creates the camera's publisher and renderer. Throws std::invalid_argument for a bad config and
  // std::runtime_error when its frame does not fit the pools or another process publishes the same
  // camera name. The host must outlive the stream.
  CameraStream(StreamingHost& host, const CameraConfig& config);
  ~CameraStream();
  CameraStream(const CameraStream&) = delete;
  CameraStream& operator=(const CameraStream&) = delete;

  // Loans a chunk, renders `scene` seen from X_WC into it and publishes it, stamped with
  // `sim_time_s`. Returns true when a frame was published; false when nobody subscribes (nothing is
  // rendered) or no chunk was free (the frame is dropped for everyone and counted). Never blocks on
  // subscribers. Calls poll_settings() first. Called by the camera thread at the camera's rate;
  // allocates nothing after the first frame.
  bool render_and_publish(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC, double sim_time_s);

  // The two halves of render_and_publish, for callers that fill frames themselves (benchmarks,
  // recorded images): loan_frame() takes a chunk and writes the header (sequence, time stamps,
  // layout, pose); the caller writes frame_pixels() (and the annotations, if any) and then hands the
  // frame to publish_frame(), which stamps publish_mono_ns. loan_frame() returns nullptr when no
  // chunk is free (the frame is counted as dropped). Camera thread only.
  FrameHeader* loan_frame(const Eigen::Isometry3d& X_WC, double sim_time_s) noexcept;
  void publish_frame(FrameHeader* frame) noexcept;

  // Changes the noise filters from any thread; the next frame uses them. Throws
  // std::invalid_argument for out-of-range values.
  void set_noise(const NoiseConfig& noise);

  // Takes pending settings (set_noise() and NoiseRequests on the settings topic), applies the last
  // valid one and republishes the CameraInfo. Returns true when the settings changed. Camera thread,
  // between frames; never blocks (the set_noise() hand-over is a try_lock), allocates nothing.
  bool poll_settings() noexcept;
  // The noise filters in use. Camera thread.
  const NoiseConfig& noise() const noexcept;

  bool has_subscribers() const noexcept;
  StreamStats stats() const noexcept;
  const CameraConfig& config() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

// True while RouDi lists a frames publisher of camera `name` on this machine. RouDi updates its
// list in its discovery loop, a little after a stream is made or destroyed (a robot removed while
// doppel runs waits for its cameras to go, so that their names can be used again at once).
// Requires a StreamingHost (or a connected client) in this process.
bool camera_offered(const std::string& name);

}  // namespace doppel::camera
