#include "camera/annotations.h"

namespace doppel::camera {

const char* to_string(AnnotationKind kind) noexcept {
  switch (kind) {
    case AnnotationKind::kBall: return "ball";
    case AnnotationKind::kGoalPost: return "goal_post";
    case AnnotationKind::kSidePole: return "side_pole";
    case AnnotationKind::kRobot: return "robot";
    case AnnotationKind::kLineL: return "line_l";
    case AnnotationKind::kLineT: return "line_t";
    case AnnotationKind::kLineX: return "line_x";
  }
  return "unknown";
}

}  // namespace doppel::camera
