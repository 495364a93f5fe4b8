#include "physics/field.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace doppel::physics {
namespace {

int count(const std::vector<VisualShape>& shapes, ObjectKind kind) {
  int n = 0;
  for (const VisualShape& s : shapes) n += s.kind == kind ? 1 : 0;
  return n;
}

TEST(FieldTest, CarpetCoversTheFieldAndItsBorderWithItsTopOnTheGround) {
  const auto sut = field_shapes();

  ASSERT_EQ(count(sut, ObjectKind::kCarpet), 1);
  const VisualShape& carpet = sut.front();
  EXPECT_EQ(carpet.kind, ObjectKind::kCarpet);
  EXPECT_NEAR(carpet.size_m.x(), 6.0 + 2 * 0.7, 1e-12);  // A + 2 I
  EXPECT_NEAR(carpet.size_m.y(), 4.0 + 2 * 0.7, 1e-12);  // B + 2 I
  EXPECT_NEAR(carpet.X_WS.translation().z() + 0.5 * carpet.size_m.z(), 0.0, 1e-12);
}

TEST(FieldTest, GoalPostsStandOnTheGoalLinesWithTheRuleWidthBetweenThem) {
  const auto sut = field_shapes();

  int posts = 0;
  for (const VisualShape& s : sut) {
    if (s.kind != ObjectKind::kGoalPost) continue;
    ++posts;
    EXPECT_EQ(s.type, ShapeType::kCylinder);
    EXPECT_NEAR(std::abs(s.X_WS.translation().x()), 3.0, 1e-12);
    EXPECT_NEAR(std::abs(s.X_WS.translation().y()) - s.size_m.x(), 0.75, 1e-12);  // D / 2 to the inner face
    EXPECT_NEAR(s.size_m.y(), 0.9, 1e-12);
    const bool yellow = s.X_WS.translation().x() > 0;
    EXPECT_EQ(s.colour.r, yellow ? kGoalYellow.r : kGoalBlue.r);
  }
  EXPECT_EQ(posts, 4);
  EXPECT_EQ(count(sut, ObjectKind::kGoalBar), 2);
  EXPECT_EQ(count(sut, ObjectKind::kGoalNet), 8);
}

TEST(FieldTest, LandmarkPolesHaveThreeBandsBesideTheCentreLine) {
  const auto sut = field_shapes();

  int bands = 0;
  double top = 0.0;
  for (const VisualShape& s : sut) {
    if (s.kind != ObjectKind::kSidePole) continue;
    ++bands;
    EXPECT_NEAR(s.X_WS.translation().x(), 0.0, 1e-12);
    EXPECT_NEAR(std::abs(s.X_WS.translation().y()), 2.0 + 0.4, 1e-12);
    top = std::max(top, s.X_WS.translation().z() + 0.5 * s.size_m.y());
  }
  EXPECT_EQ(bands, 6);
  EXPECT_NEAR(top, 0.9, 1e-12);
}

TEST(FieldTest, LinesAndCentreCircleLieFlatAtTheRulePositions) {
  const auto sut = field_shapes();

  int rings = 0;
  for (const VisualShape& s : sut) {
    if (s.kind != ObjectKind::kFieldLine) continue;
    EXPECT_LE(s.X_WS.translation().z() + 0.5 * s.size_m.z(), 0.0021);  // flat on the carpet
    if (s.type == ShapeType::kRing) {
      ++rings;
      EXPECT_NEAR(s.size_m.x() + s.size_m.y(), 1.2, 1e-12);  // outer + inner radius = H
      EXPECT_NEAR(s.size_m.x() - s.size_m.y(), 0.05, 1e-12);
    }
  }
  EXPECT_EQ(rings, 1);
  EXPECT_GE(count(sut, ObjectKind::kFieldLine), 14);
}

TEST(FieldTest, FeaturesAreTheRuleCrossings) {
  const auto sut = field_features();

  int l = 0, t = 0, x = 0;
  for (const FieldFeature& f : sut) {
    const double ax = std::abs(f.position_W.x());
    const double ay = std::abs(f.position_W.y());
    switch (f.type) {
      case FieldFeatureType::kL:
        ++l;
        EXPECT_TRUE((ax == 3.0 && ay == 2.0) || (std::abs(ax - 2.4) < 1e-12 && ay == 1.1)) << ax << "," << ay;
        break;
      case FieldFeatureType::kT:
        ++t;
        EXPECT_TRUE((ax == 3.0 && ay == 1.1) || (ax == 0.0 && ay == 2.0)) << ax << "," << ay;
        break;
      case FieldFeatureType::kX:
        ++x;
        EXPECT_TRUE((ax == 0.0 && ay == 0.6) || (std::abs(ax - 1.2) < 1e-12 && ay == 0.0)) << ax << "," << ay;
        break;
    }
  }
  EXPECT_EQ(l, 8);
  EXPECT_EQ(t, 6);
  EXPECT_EQ(x, 4);
}

TEST(FieldTest, BallIsAnOrangeTennisBall) {
  const VisualShape sut = ball_shape({1.0, 2.0, 0.0335});

  EXPECT_EQ(sut.type, ShapeType::kSphere);
  EXPECT_EQ(sut.kind, ObjectKind::kBall);
  EXPECT_NEAR(2.0 * sut.size_m.x(), 0.067, 1e-12);
  EXPECT_EQ(sut.object_id, kBallObjectId);
}

TEST(FieldTest, NonPositiveDimensionsAreRejected) {
  FieldSpec spec;
  spec.goal_width_m = 0.0;
  EXPECT_THROW(field_shapes(spec), std::invalid_argument);
  spec = FieldSpec{};
  spec.crossbar_lower_edge_m = 1.0;
  EXPECT_THROW(field_shapes(spec), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::physics
