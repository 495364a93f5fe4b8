#pragma once
// The RoboCup Humanoid KidSize field of 2011 as visual shapes: carpet with its border, white lines,
// yellow and sky-blue goals with nets, the two landmark poles and the orange ball, plus the field-line
// crossings (L, T, X) a localisation module looks for. Engine-free (Eigen and scene_view.h only):
// renderers draw these shapes and physics backends may build static bodies from the same list.
//
// World frame as in scene_view.h: origin at the field centre on the carpet surface, x towards the
// yellow goal, y to the left when looking along x, z up.

#include <Eigen/Core>

#include <cstdint>
#include <vector>

#include "physics/scene_view.h"

namespace doppel::physics {

// Dimensions from "RoboCup Soccer Humanoid League Rules and Setup for the 2011 competition in
// Istanbul", Law 1 (field figure: A..I) and Law 2. The ball is the orange tennis ball the thesis names
// (section 3.1.1); its diameter follows the ITF tennis-ball rule (6.54..6.86 cm).
struct FieldSpec {
  double field_length_m = 6.0;            // A: touch-line length, between goal-line centres
  double field_width_m = 4.0;             // B: goal-line length, between touch-line centres
  double goal_depth_m = 0.5;              // C: from the goal line to the back of the goal
  double goal_width_m = 1.5;              // D: between the inner faces of the posts
  double goal_area_length_m = 0.6;        // E: goal-area depth along x
  double goal_area_width_m = 2.2;         // F: goal-area extent along y
  double penalty_mark_distance_m = 1.8;   // G: penalty-mark centre from the goal-line centre
  double centre_circle_diameter_m = 1.2;  // H: outer diameter of the centre circle
  double border_strip_width_m = 0.7;      // I: carpet beyond the outer lines
  double line_width_m = 0.05;             // every white line
  double penalty_mark_size_m = 0.1;       // arm length of the penalty cross
  double goal_post_diameter_m = 0.1;      // posts and crossbar
  double goal_height_m = 0.9;             // top of the posts and of the crossbar
  double crossbar_lower_edge_m = 0.8;     // free height under the crossbar
  double pole_diameter_m = 0.2;           // landmark poles
  double pole_height_m = 0.9;             // three bands of a third each
  double pole_offset_m = 0.4;             // pole centre beyond the touch-line centre, on the centre line
  double ball_diameter_m = 0.067;         // orange tennis ball
  double line_thickness_m = 0.002;        // painted height of a line above the carpet (visual only)
};

// object_id values of the field's objects (robots use their own, from kFirstRobotObjectId up).
inline constexpr uint16_t kCarpetObjectId = 1;
inline constexpr uint16_t kFieldLinesObjectId = 2;
inline constexpr uint16_t kYellowGoalLeftPostId = 10;   // yellow goal (x > 0), post at y > 0
inline constexpr uint16_t kYellowGoalRightPostId = 11;  // yellow goal, post at y < 0
inline constexpr uint16_t kYellowGoalId = 12;           // its crossbar and net
inline constexpr uint16_t kBlueGoalLeftPostId = 20;     // blue goal (x < 0), post at y < 0 (left seen from the field)
inline constexpr uint16_t kBlueGoalRightPostId = 21;    // blue goal, post at y > 0
inline constexpr uint16_t kBlueGoalId = 22;             // its crossbar and net
inline constexpr uint16_t kLeftPoleId = 30;             // pole at y > 0
inline constexpr uint16_t kRightPoleId = 31;            // pole at y < 0
inline constexpr uint16_t kBallObjectId = 40;
inline constexpr uint16_t kFirstRobotObjectId = 100;

inline constexpr Rgb kCarpetGreen{30, 140, 40};
inline constexpr Rgb kLineWhite{250, 250, 250};
inline constexpr Rgb kGoalYellow{240, 210, 20};
inline constexpr Rgb kGoalBlue{40, 150, 230};  // "sky blue"
inline constexpr Rgb kNetWhite{225, 225, 225};
inline constexpr Rgb kBallOrange{255, 120, 0};
inline constexpr Rgb kTeamCyan{0, 200, 220};      // team markers (league standard cyan and magenta)
inline constexpr Rgb kTeamMagenta{220, 0, 170};

// Static shapes of the field: carpet (one kBox whose top is z = 0), lines (flat kBox and the centre
// circle as a kRing, tops at line_thickness_m), goals (kCylinder posts, kBox crossbar and net panels)
// and the poles (three kCylinder bands each). Throws std::invalid_argument for non-positive sizes.
std::vector<VisualShape> field_shapes(const FieldSpec& spec = {});

// The ball resting with its centre at `centre_W` (z = radius lies on the carpet).
VisualShape ball_shape(const Eigen::Vector3d& centre_W, const FieldSpec& spec = {});

enum class FieldFeatureType : uint8_t {
  kL,  // two lines meet at a corner
  kT,  // a line ends on another
  kX,  // two lines cross (centre line with the circle, penalty marks)
};

struct FieldFeature {
  FieldFeatureType type = FieldFeatureType::kL;
  Eigen::Vector3d position_W = Eigen::Vector3d::Zero();  // crossing of the line centres, m, z = 0
  double heading_rad = 0.0;  // world yaw of the feature: L = bisector into the corner's arms,
                             // T = along the stem away from the bar, X = direction of one line
};

// The 8 L, 6 T and 4 X crossings of the lines that field_shapes() draws.
std::vector<FieldFeature> field_features(const FieldSpec& spec = {});

}  // namespace doppel::physics
