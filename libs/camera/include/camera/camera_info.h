#pragma once
// What a publishing camera and its clients exchange besides frames, as plain values laid out for
// shared memory: the camera's description and current settings (its "info" topic) and a request to
// change its noise (its "settings" topic). Shared by the client library and the publisher, so a
// client needs neither the renderer nor the publisher to read them.

#include <cstdint>

#include "camera/lens.h"
#include "camera/noise.h"

namespace doppel::camera {

// Published once per camera on ("DoppelCamera", name, "info"), for `doppel-camera list`.
struct CameraInfo {
  char name[64] = {};           // camera name, NUL-terminated
  char body[64] = {};           // body it is mounted on ("" for a world mount)
  uint32_t format = 0;          // PixelFormat
  int32_t width_px = 0;         // resolution
  int32_t height_px = 0;
  double fps = 0.0;             // frame rate, 1/s of simulation time
  LensConfig lens;              // intrinsics
  uint32_t payload_bytes = 0;   // chunk payload per frame
  int32_t pid = 0;              // publishing process
  NoiseConfig noise;            // noise filters in use (republished whenever they change)
  uint64_t noise_request_id = 0;      // NoiseRequest::request_id that set them; 0 = configuration
  uint64_t noise_from_sequence = 0;   // first frame sequence number rendered with them
  uint64_t settings_rejected = 0;     // NoiseRequests refused (out of range), since start
  int32_t robot_file_order = 0;       // CameraConfig::robot_file_order: doppel-run's /dev/videoN follow it
};

// A settings change sent to a running camera on ("DoppelCamera", <name>, "settings"). The camera
// applies it before its next frame and republishes its CameraInfo with `request_id`, which is how
// the sender learns that (and from which frame) it took effect. Out-of-range values are refused and
// counted in CameraInfo::settings_rejected.
struct NoiseRequest {
  uint64_t request_id = 0;  // chosen by the sender, non-zero, echoed in CameraInfo::noise_request_id
  NoiseConfig noise;        // the complete new settings
};

}  // namespace doppel::camera
