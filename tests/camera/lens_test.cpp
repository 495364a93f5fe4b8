#include "camera/lens.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace doppel::camera {
namespace {

constexpr double kPi = std::numbers::pi;

LensConfig simple_pinhole() {
  LensConfig c;
  c.model = LensModel::kPinhole;
  c.fx_px = 500.0;
  c.fy_px = 500.0;
  c.cx_px = 319.5;
  c.cy_px = 239.5;
  return c;
}

TEST(LensTest, PinholeProjectsKnownPointsOnExpectedPixels) {
  const Lens sut(simple_pinhole(), 640, 480);
  Eigen::Vector2d px;

  ASSERT_TRUE(sut.project({0.1, -0.2, 1.0}, &px));
  EXPECT_NEAR(px.x(), 319.5 + 500.0 * 0.1, 1e-12);
  EXPECT_NEAR(px.y(), 239.5 - 500.0 * 0.2, 1e-12);
  ASSERT_TRUE(sut.project({0.0, 0.0, 3.0}, &px));
  EXPECT_NEAR(px.x(), 319.5, 1e-12);
  EXPECT_NEAR(px.y(), 239.5, 1e-12);
  EXPECT_FALSE(sut.project({0.0, 0.0, -1.0}, &px));
}

TEST(LensTest, PinholeFromHfovPutsTheHalfAngleOnTheImageBorder) {
  const Lens sut(pinhole_from_hfov(640, 480, 90.0), 640, 480);
  Eigen::Vector2d px;

  ASSERT_TRUE(sut.project({1.0, 0.0, 1.0}, &px));  // 45 degrees to the right

  EXPECT_NEAR(sut.config().fx_px, 320.0, 1e-9);
  EXPECT_NEAR(px.x(), 639.5, 1e-9);  // right edge of the last pixel column
}

TEST(LensTest, RadialAndTangentialDistortionMatchHandComputedValues) {
  LensConfig radial = simple_pinhole();
  radial.k1 = -0.2;
  LensConfig tangential = simple_pinhole();
  tangential.p1 = 0.01;
  const Lens sut_radial(radial, 640, 480);
  const Lens sut_tangential(tangential, 640, 480);
  Eigen::Vector2d px;

  // x = 0.5, r^2 = 0.25, 1 + k1 r^2 = 0.95, x_d = 0.475.
  ASSERT_TRUE(sut_radial.project({0.5, 0.0, 1.0}, &px));
  EXPECT_NEAR(px.x(), 319.5 + 500.0 * 0.475, 1e-9);
  EXPECT_NEAR(px.y(), 239.5, 1e-9);
  // x = 0.2, y = 0.1, r^2 = 0.05: x_d = x + 2 p1 x y = 0.2004, y_d = y + p1 (r^2 + 2 y^2) = 0.1007.
  ASSERT_TRUE(sut_tangential.project({0.2, 0.1, 1.0}, &px));
  EXPECT_NEAR(px.x(), 319.5 + 500.0 * 0.2004, 1e-9);
  EXPECT_NEAR(px.y(), 239.5 + 500.0 * 0.1007, 1e-9);
}

TEST(LensTest, FisheyeModelsFollowTheirRadiusFormulas) {
  LensConfig c;
  c.fx_px = c.fy_px = 300.0;
  c.cx_px = 319.5;
  c.cy_px = 239.5;
  const Eigen::Vector3d at_60deg(std::sin(kPi / 3.0), 0.0, std::cos(kPi / 3.0));
  const Eigen::Vector3d at_80deg_down(0.0, std::sin(80.0 * kPi / 180.0), std::cos(80.0 * kPi / 180.0));
  Eigen::Vector2d px;

  c.model = LensModel::kEquidistant;
  ASSERT_TRUE(Lens(c, 640, 480).project(at_60deg, &px));
  EXPECT_NEAR(px.x(), 319.5 + 300.0 * kPi / 3.0, 1e-9);  // r = f theta
  c.model = LensModel::kEquisolid;
  ASSERT_TRUE(Lens(c, 640, 480).project(at_60deg, &px));
  EXPECT_NEAR(px.x(), 319.5 + 2.0 * 300.0 * 0.5, 1e-9);  // r = 2 f sin(30 deg)
  c.model = LensModel::kStereographic;
  ASSERT_TRUE(Lens(c, 640, 480).project(at_80deg_down, &px));
  EXPECT_NEAR(px.y(), 239.5 + 2.0 * 300.0 * std::tan(40.0 * kPi / 180.0), 1e-9);  // r = 2 f tan(theta/2)
  EXPECT_NEAR(px.x(), 319.5, 1e-9);
}

TEST(LensTest, FisheyeRejectsDirectionsOutsideItsFieldOfView) {
  LensConfig c = fisheye_from_hfov(LensModel::kEquidistant, 640, 480, 100.0);
  c.fov_deg = 120.0;
  const Lens sut(c, 640, 480);
  Eigen::Vector2d px;

  EXPECT_TRUE(sut.project({std::sin(0.99 * kPi / 3.0), 0.0, std::cos(0.99 * kPi / 3.0)}, &px));
  EXPECT_FALSE(sut.project({std::sin(70.0 * kPi / 180.0), 0.0, std::cos(70.0 * kPi / 180.0)}, &px));
  EXPECT_FALSE(sut.project({0.0, 0.0, -1.0}, &px));
}

TEST(LensTest, ProjectionAndUnprojectionAreExactInversesForEveryModel) {
  LensConfig distorted = simple_pinhole();
  distorted.k1 = -0.28;
  distorted.k2 = 0.07;
  distorted.k3 = -0.004;
  distorted.p1 = 0.001;
  distorted.p2 = -0.0015;
  const LensConfig lenses[] = {
      simple_pinhole(),
      distorted,
      fisheye_from_hfov(LensModel::kEquidistant, 640, 480, 120.0),
      fisheye_from_hfov(LensModel::kEquisolid, 640, 480, 120.0),
      fisheye_from_hfov(LensModel::kStereographic, 640, 480, 140.0),
  };
  for (const LensConfig& config : lenses) {
    const Lens sut(config, 640, 480);
    int checked = 0;
    for (double v = 0.0; v <= 479.0; v += 31.9) {
      for (double u = 0.0; u <= 639.0; u += 42.6) {
        Eigen::Vector3d ray;
        Eigen::Vector2d back;
        ASSERT_TRUE(sut.unproject({u, v}, &ray)) << to_string(config.model) << " " << u << "," << v;
        EXPECT_NEAR(ray.norm(), 1.0, 1e-12);
        ASSERT_TRUE(sut.project(ray * 2.5, &back));
        EXPECT_NEAR(back.x(), u, 1e-6) << to_string(config.model);
        EXPECT_NEAR(back.y(), v, 1e-6) << to_string(config.model);
        Eigen::Vector3d again;
        ASSERT_TRUE(sut.unproject(back, &again));
        EXPECT_NEAR((again - ray).norm(), 0.0, 1e-9);
        ++checked;
      }
    }
    EXPECT_GT(checked, 200);
  }
}

TEST(LensTest, PinholeWhoseDistortionFoldsDoesNotProjectBeyondTheFold) {
  LensConfig c = simple_pinhole();
  c.k1 = -0.5;  // r_d = r - 0.5 r^3 stops growing at r = sqrt(2/3)
  const Lens sut(c, 640, 480);
  Eigen::Vector2d px;
  Eigen::Vector3d ray;

  EXPECT_TRUE(sut.project({0.7, 0.0, 1.0}, &px));
  EXPECT_FALSE(sut.project({0.9, 0.0, 1.0}, &px));
  // Largest distorted radius is sqrt(2/3) (1 - 1/3) = 0.544: 500 px * 0.6 lies beyond it.
  EXPECT_FALSE(sut.unproject({319.5 + 500.0 * 0.6, 239.5}, &ray));
}

TEST(LensTest, InvalidConfigurationsAreRejectedWithAnError) {
  LensConfig c = simple_pinhole();
  c.fov_deg = 180.0;
  EXPECT_THROW(Lens(c, 640, 480), std::invalid_argument);
  c = simple_pinhole();
  c.fx_px = 0.0;
  EXPECT_THROW(Lens(c, 640, 480), std::invalid_argument);
  EXPECT_THROW(Lens(simple_pinhole(), 0, 480), std::invalid_argument);
  EXPECT_THROW(fisheye_from_hfov(LensModel::kEquidistant, 640, 480, 160.0), std::invalid_argument);
  EXPECT_THROW(pinhole_from_hfov(640, 480, 180.0), std::invalid_argument);
  EXPECT_THROW(parse_lens_model("fisheye"), std::invalid_argument);
  EXPECT_EQ(parse_lens_model("equisolid"), LensModel::kEquisolid);
}

}  // namespace
}  // namespace doppel::camera
