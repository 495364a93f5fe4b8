// Convex hulls (physics/convex_hull.h) and the `convex` shape of a hand-written figure: vertices,
// faces and mass properties against closed-form solids.
#include "physics/convex_hull.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "rigs.h"

namespace doppel::physics {
namespace {

TEST(ConvexHull, PointsOnASphereAreAllVerticesAndInsidePointsAreDropped) {
  // 2000 points on a sphere of radius 0.1 (every one on the hull) and 500 inside it.
  std::mt19937 random(7);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(0.0, 0.09);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 2500; ++i) {
    const Eigen::Vector3d d = Eigen::Vector3d(normal(random), normal(random), normal(random)).normalized();
    points.push_back(Eigen::Vector3d(1.0, 2.0, 3.0) + (i < 2000 ? 0.1 : uniform(random)) * d);
  }
  const auto sut = convex_hull(points);

  EXPECT_EQ(sut->vertices.size(), 2000U);
  for (const Eigen::Vector3d& v : sut->vertices) {
    EXPECT_NEAR((v - Eigen::Vector3d(1.0, 2.0, 3.0)).norm(), 0.1, 1e-12);  // exactly input points
  }
  // A polyhedron inscribed in the sphere: a little less than 4/3 pi r^3 and 0.4 r^2 per kg.
  const double sphere = 4.0 / 3.0 * std::numbers::pi * 1e-3;
  EXPECT_LT(sut->volume_m3, sphere);
  EXPECT_GT(sut->volume_m3, 0.98 * sphere);
  EXPECT_LT((sut->centroid - Eigen::Vector3d(1.0, 2.0, 3.0)).norm(), 1e-3);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(sut->inertia_per_kg(a, a), 0.4 * 0.01, 0.03 * 0.004);
  // Every vertex lies on or inside every face plane.
  for (const Eigen::Vector4d& plane : sut->planes) {
    for (const Eigen::Vector3d& v : sut->vertices) EXPECT_LE(plane.head<3>().dot(v), plane.w() + 1e-12);
  }
}

TEST(ConvexHull, PointsWithoutVolumeAreRefused) {
  EXPECT_THROW(convex_hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}), std::invalid_argument);
  EXPECT_THROW(convex_hull({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 0}}), std::invalid_argument);
}

TEST(ConvexShape, AHullShapeWithAMassHasTheInertiaOfItsSolid) {
  // A convex shape listing the corners of a 0.2 x 0.1 x 0.05 box (and its centre, not a vertex)
  // with 2 kg: the box's inertia m (b^2 + c^2) / 12 ..., centred at the shape's offset.
  std::string corners;
  for (int i = 0; i < 8; ++i) {
    corners += "point_m { x: " + std::string(i & 1 ? "0.1" : "-0.1") + " y: " + (i & 2 ? "0.05" : "-0.05") +
               " z: " + (i & 4 ? "0.025" : "-0.025") + " } ";
  }
  const RobotModel sut = test::robot_from_text(
      "name: \"c\"\nfigure { body { name: \"b\" shape { convex { " + corners +
      "point_m { } } pose { position_m { z: 0.3 } } } mass_kg: 2 } }");
  const BodyModel& b = sut.bodies[0];
  EXPECT_TRUE(b.X_RB.translation().isApprox(Eigen::Vector3d(0, 0, 0.3)));
  Eigen::Vector3d moments = b.inertia_kg_m2;
  std::sort(moments.data(), moments.data() + 3);
  const Eigen::Vector3d box(2.0 * (0.01 + 0.0025) / 12.0, 2.0 * (0.04 + 0.0025) / 12.0, 2.0 * (0.04 + 0.01) / 12.0);
  EXPECT_TRUE(moments.isApprox(box, 1e-9)) << moments.transpose();
  ASSERT_EQ(b.shapes.size(), 1U);
  EXPECT_EQ(b.shapes[0].hull->vertices.size(), 8U);
  EXPECT_TRUE(b.shapes[0].size_m.isApprox(Eigen::Vector3d(0.1, 0.05, 0.025)));
}

TEST(ConvexShape, AFlatPointListNamesItsLine) {
  try {
    test::robot_from_text("name: \"c\"\nfigure { body { name: \"b\"\n shape { convex { point_m { x: 1 } point_m { y: 1 } point_m { } } } mass_kg: 1 } }");
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("rig.textproto:3:"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no convex hull"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace doppel::physics
