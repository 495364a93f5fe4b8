#include "camera/frame.h"

namespace doppel::camera {
namespace {

constexpr size_t align_up(size_t n) noexcept { return (n + kFrameAlignment - 1) / kFrameAlignment * kFrameAlignment; }

}  // namespace

size_t frame_payload_bytes(const CameraConfig& config) noexcept {
  size_t n = align_up(sizeof(FrameHeader));
  n += align_up(frame_bytes(config.format, config.width_px, config.height_px));
  if (config.annotations) n += align_up(sizeof(FrameAnnotations));
  return n;
}

bool frame_valid(const FrameHeader* h, size_t payload_bytes) noexcept {
  if (h == nullptr || payload_bytes < sizeof(FrameHeader)) return false;
  if (h->magic != kFrameMagic || h->version != kFrameVersion || h->header_bytes != sizeof(FrameHeader)) return false;
  if (h->format > static_cast<uint32_t>(PixelFormat::kBayerGbrg) || h->width_px <= 0 || h->height_px <= 0) {
    return false;
  }
  const auto format = static_cast<PixelFormat>(h->format);
  if (h->stride_bytes != row_bytes(format, h->width_px)) return false;
  if (static_cast<uint64_t>(h->pixel_bytes) != static_cast<uint64_t>(h->stride_bytes) * h->height_px) return false;
  if (h->pixel_offset < sizeof(FrameHeader) || uint64_t{h->pixel_offset} + h->pixel_bytes > payload_bytes) {
    return false;
  }
  if (h->annotation_offset != 0) {
    if (h->annotation_bytes != sizeof(FrameAnnotations)) return false;
    if (h->annotation_offset < uint64_t{h->pixel_offset} + h->pixel_bytes) return false;
    if (uint64_t{h->annotation_offset} + h->annotation_bytes > payload_bytes) return false;
    if (frame_annotations(h)->count > kMaxAnnotations) return false;
  }
  return h->camera_name[sizeof(h->camera_name) - 1] == '\0';
}

Eigen::Isometry3d frame_camera_pose(const FrameHeader& h) noexcept {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.translation() = Eigen::Vector3d(h.position_w_m[0], h.position_w_m[1], h.position_w_m[2]);
  X_WC.linear() =
      Eigen::Quaterniond(h.orientation_w[0], h.orientation_w[1], h.orientation_w[2], h.orientation_w[3])
          .normalized()
          .toRotationMatrix();
  return X_WC;
}

}  // namespace doppel::camera
