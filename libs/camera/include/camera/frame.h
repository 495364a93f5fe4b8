#pragma once
// The layout of one frame in a shared-memory chunk: a fixed header, the pixels, then (optionally) the
// ground-truth annotations. Publisher and subscribers agree on it without iceoryx types, so a
// client reads frames with plain pointers. All offsets are from the start of the header.

#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>

#include "camera/annotations.h"
#include "camera/camera_config.h"
#include "camera/lens.h"
#include "camera/pixel_format.h"

namespace doppel::camera {

inline constexpr uint32_t kFrameMagic = 0x46435044u;  // "DPCF" little-endian
inline constexpr uint16_t kFrameVersion = 1;
inline constexpr size_t kFrameAlignment = 64;         // payload alignment of chunks and sections

struct FrameHeader {
  uint32_t magic = kFrameMagic;       // kFrameMagic
  uint16_t version = kFrameVersion;   // kFrameVersion
  uint16_t header_bytes = 0;          // sizeof(FrameHeader)
  uint64_t sequence = 0;              // per camera, +1 per frame due; a gap means frames were dropped
  int64_t sim_time_ns = 0;            // simulation time of the rendered scene
  int64_t exposure_time_ns = 0;       // simulation time of the configured exposure instant
  int64_t wall_time_ns = 0;           // CLOCK_REALTIME when rendering started
  int64_t render_start_mono_ns = 0;   // CLOCK_MONOTONIC when rendering started
  int64_t publish_mono_ns = 0;        // CLOCK_MONOTONIC just before publishing (latency reference)
  uint32_t format = 0;                // PixelFormat
  int32_t width_px = 0;               // image width
  int32_t height_px = 0;              // image height
  uint32_t stride_bytes = 0;          // bytes per row
  uint32_t pixel_offset = 0;          // start of the pixels
  uint32_t pixel_bytes = 0;           // stride_bytes * height_px
  uint32_t annotation_offset = 0;     // start of a FrameAnnotations, 0 when the frame carries none
  uint32_t annotation_bytes = 0;      // sizeof(FrameAnnotations) or 0
  double position_w_m[3] = {0, 0, 0};        // camera origin in the world frame (X_WC translation)
  double orientation_w[4] = {1, 0, 0, 0};    // X_WC rotation as quaternion w, x, y, z
  LensConfig lens;                    // intrinsics of these pixels
  double fps = 0.0;                   // configured frame rate
  uint64_t frames_dropped = 0;        // frames the publisher could not deliver so far (no free chunk)
  char camera_name[64] = {};          // NUL-terminated camera name
};

// Bytes of the chunk payload for a camera: header, pixels, annotations (each 64-byte aligned).
size_t frame_payload_bytes(const CameraConfig& config) noexcept;

// True when `header` is a complete frame of `payload_bytes`: magic, version and every section
// within the payload. rt-safe.
bool frame_valid(const FrameHeader* header, size_t payload_bytes) noexcept;

inline const uint8_t* frame_pixels(const FrameHeader* h) noexcept {
  return reinterpret_cast<const uint8_t*>(h) + h->pixel_offset;
}
inline const FrameAnnotations* frame_annotations(const FrameHeader* h) noexcept {
  return h->annotation_offset == 0
             ? nullptr
             : reinterpret_cast<const FrameAnnotations*>(reinterpret_cast<const uint8_t*>(h) + h->annotation_offset);
}

// X_WC of the frame. rt-safe.
Eigen::Isometry3d frame_camera_pose(const FrameHeader& h) noexcept;

}  // namespace doppel::camera
