#pragma once
// Ground truth that travels with each frame: where the ball, goal posts, landmark poles, robots and
// field-line crossings are in the image and whether the camera sees them. Plain fixed-size values,
// laid out for shared memory, so a vision module can be checked against the truth and a
// localisation module can be fed the truth without decoding any image.

#include <cstdint>

namespace doppel::camera {

enum class AnnotationKind : uint8_t {
  kBall = 0,
  kGoalPost = 1,
  kSidePole = 2,
  kRobot = 3,
  kLineL = 4,  // field-line corner
  kLineT = 5,  // field-line T junction
  kLineX = 6,  // field-line crossing
};

const char* to_string(AnnotationKind kind) noexcept;

struct Annotation {
  AnnotationKind kind = AnnotationKind::kBall;  // what it is
  uint8_t in_fov = 0;      // 1 when the reference point projects inside the image
  uint8_t visible = 0;     // 1 when the camera sees it: objects with visible_px > 0 (or, without
                           // pixels, an unoccluded sample point), features unoccluded and in_fov
  uint8_t reserved = 0;
  uint16_t object_id = 0;  // physics::VisualShape::object_id (features: index in field_features())
  uint16_t reserved2 = 0;
  uint32_t visible_px = 0;  // pixels showing it in this frame (0 when rendered without pixels)
  float u_px = 0.0f;        // reference point in the image (ball centre, foot point of posts, poles
  float v_px = 0.0f;        // and robots, crossing of features); NaN when it does not project
  float bbox_min_u = 0.0f;  // bounding box of the projected object, clipped to the image, pixels;
  float bbox_min_v = 0.0f;  // all zero when nothing of it projects into the image
  float bbox_max_u = 0.0f;
  float bbox_max_v = 0.0f;
  float distance_m = 0.0f;  // camera to reference point
  float x_w_m = 0.0f;       // reference point in the world frame, m
  float y_w_m = 0.0f;
  float z_w_m = 0.0f;
  float heading_rad = 0.0f;  // features: world yaw (see physics::FieldFeature); objects: 0
};

inline constexpr uint32_t kMaxAnnotations = 96;

struct FrameAnnotations {
  uint32_t count = 0;                     // valid entries in `items`
  uint32_t dropped = 0;                   // objects left out because `items` was full
  Annotation items[kMaxAnnotations] = {};  // ball, posts, poles, robots, then features
};

}  // namespace doppel::camera
