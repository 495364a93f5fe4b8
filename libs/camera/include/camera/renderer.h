#pragma once
// CPU renderer: one ray per pixel from a table the lens fills once, cast against the scene the
// physics world describes (physics::SceneView). The ground and everything flat on it (carpet, lines,
// centre circle) is a texture hit analytically; upright shapes (posts, nets, poles, ball, robot
// parts) are analytic primitives culled per 16x16 tile by cone tests. Rows are shaded, passed
// through the noise filter and encoded straight into the output (e.g. a shared-memory chunk).
// Knows no physics engine and no iceoryx.

#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <vector>

#include "camera/annotations.h"
#include "camera/lens.h"
#include "camera/noise.h"
#include "camera/pixel_format.h"
#include "physics/field.h"
#include "physics/scene_view.h"

namespace doppel::camera {

struct RenderStats {
  uint32_t primitives = 0;       // upright shapes considered this frame
  uint32_t tile_entries = 0;     // primitive-in-tile pairs after culling
  bool ground_rebuilt = false;   // the flat shapes changed and the ground texture was redrawn
};

class Renderer {
 public:
  // Throws std::invalid_argument for a bad lens or size, an odd width with YUV422, threads
  // outside 1..16. Starts threads - 1 worker threads.
  Renderer(const LensConfig& lens, int width_px, int height_px, PixelFormat format, int threads = 1);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Renders `scene` seen from camera pose X_WC into `out` (frame_bytes(format, width, height) bytes)
  // and, when `annotations` is not null, fills the ground truth. `frame` keys the noise. Not rt-safe
  // in the strict sense (it wakes worker threads), but allocates nothing once the scene's size has
  // been seen.
  void render(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC, uint64_t frame, uint8_t* out,
              FrameAnnotations* annotations);

  // Ground truth only, without pixels: visibility comes from occlusion rays, visible_px stays 0.
  void annotate(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC, FrameAnnotations* annotations);

  // Setup: noise for the following frames (validates, throws std::invalid_argument).
  void set_noise(const NoiseConfig& config);
  // Setup: the field-line crossings annotated (default: physics::field_features()).
  void set_field_features(std::vector<physics::FieldFeature> features);

  const Lens& lens() const noexcept;
  PixelFormat format() const noexcept;
  int width_px() const noexcept;
  int height_px() const noexcept;
  RenderStats last_stats() const noexcept;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace doppel::camera
