#include "camera/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "camera/camera_config.h"
#include "physics/convex_hull.h"
#include "demo_scene.h"

namespace doppel::camera {
namespace {

// Camera 5 m above the field centre looking straight down; image right = world -y, image down = world -x.
Eigen::Isometry3d overhead(double height_m) {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.translation() = Eigen::Vector3d(0.0, 0.0, height_m);
  X_WC.linear() << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  return X_WC;
}

// Camera at `eye` looking at `target`, image x to the right, no roll.
Eigen::Isometry3d look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear().col(0) = x;
  X_WC.linear().col(1) = y;
  X_WC.linear().col(2) = z;
  X_WC.translation() = eye;
  return X_WC;
}

Eigen::Vector2d project_world(const Lens& lens, const Eigen::Isometry3d& X_WC, const Eigen::Vector3d& p_W) {
  Eigen::Vector2d px(-1.0, -1.0);
  EXPECT_TRUE(lens.project(X_WC.inverse() * p_W, &px));
  return px;
}

const uint8_t* rgb_at(const std::vector<uint8_t>& img, int w, const Eigen::Vector2d& px) {
  return &img[3 * (static_cast<size_t>(std::lround(px.y())) * w + std::lround(px.x()))];
}

const Annotation* find(const FrameAnnotations& a, AnnotationKind kind, uint16_t id) {
  for (uint32_t i = 0; i < a.count; ++i) {
    if (a.items[i].kind == kind && a.items[i].object_id == id) return &a.items[i];
  }
  return nullptr;
}

TEST(RendererTest, KnownWorldPointsLandOnPixelsOfTheirColour) {
  const LensConfig lens = pinhole_from_hfov(640, 480, 90.0);
  Renderer sut(lens, 640, 480, PixelFormat::kRgb24);
  const auto scene = make_demo_scene(0, {2.0, -1.5});
  const Eigen::Isometry3d X_WC = overhead(5.0);
  std::vector<uint8_t> img(frame_bytes(PixelFormat::kRgb24, 640, 480));

  sut.render(scene, X_WC, 0, img.data(), nullptr);

  const uint8_t* on_circle = rgb_at(img, 640, project_world(sut.lens(), X_WC, {0.6, 0.0, 0.0}));
  const uint8_t* carpet = rgb_at(img, 640, project_world(sut.lens(), X_WC, {0.3, 0.3, 0.0}));
  const uint8_t* on_touch_line = rgb_at(img, 640, project_world(sut.lens(), X_WC, {1.5, 2.0, 0.0}));
  const uint8_t* ball = rgb_at(img, 640, project_world(sut.lens(), X_WC, {2.0, -1.5, 0.067}));
  EXPECT_EQ(on_circle[0], physics::kLineWhite.r);
  EXPECT_EQ(on_touch_line[1], physics::kLineWhite.g);
  EXPECT_EQ(carpet[0], physics::kCarpetGreen.r);
  EXPECT_EQ(carpet[1], physics::kCarpetGreen.g);
  EXPECT_EQ(carpet[2], physics::kCarpetGreen.b);
  // Seen from above, the top of the ball faces the light: orange, red well above green, no blue.
  EXPECT_GT(ball[0], 200);
  EXPECT_LT(ball[2], 10);
}

struct Mask {
  double u = 0.0;
  double v = 0.0;
  int pixels = 0;
};

// Pixels whose encoded bytes change when the ball is added, and their centroid.
Mask changed_pixels(PixelFormat format, const std::vector<uint8_t>& a, const std::vector<uint8_t>& b, int w, int h) {
  Mask m;
  const size_t stride = row_bytes(format, w);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      bool differs = false;
      if (format == PixelFormat::kRgb24) {
        for (int c = 0; c < 3; ++c) differs |= a[y * stride + 3 * x + c] != b[y * stride + 3 * x + c];
      } else if (is_yuv422(format)) {
        // A pixel differs when its luma differs (chroma is shared by the pair).
        const size_t luma = y * stride + 2 * x + (format == PixelFormat::kYuyv ? 0 : 1);
        differs = a[luma] != b[luma];
      } else {
        differs = a[y * stride + x] != b[y * stride + x];
      }
      if (differs) {
        m.u += x;
        m.v += y;
        ++m.pixels;
      }
    }
  }
  if (m.pixels > 0) {
    m.u /= m.pixels;
    m.v /= m.pixels;
  }
  return m;
}

TEST(RendererTest, BallAppearsWhereTheProjectionSaysInEveryFormatAndLens) {
  const Eigen::Vector2d ball_xy(0.3, 0.25);
  const Eigen::Vector3d ball_W(ball_xy.x(), ball_xy.y(), 0.0335);
  const auto with_ball = make_demo_scene(6, ball_xy);
  physics::SceneView without_ball = with_ball;
  std::erase_if(without_ball.shapes, [](const physics::VisualShape& s) { return s.kind == physics::ObjectKind::kBall; });
  const Eigen::Isometry3d X_WC = look_at({-0.6, -0.2, 0.55}, {0.6, 0.5, 0.0});
  const LensConfig lenses[] = {pinhole_from_hfov(640, 480, 70.0),
                               fisheye_from_hfov(LensModel::kEquidistant, 640, 480, 120.0),
                               fisheye_from_hfov(LensModel::kEquisolid, 640, 480, 110.0)};
  for (const LensConfig& lens : lenses) {
    for (PixelFormat format : kAllPixelFormats) {
      Renderer sut(lens, 640, 480, format);
      std::vector<uint8_t> a(frame_bytes(format, 640, 480));
      std::vector<uint8_t> b(a.size());
      FrameAnnotations annotations;

      sut.render(with_ball, X_WC, 0, a.data(), &annotations);
      sut.render(without_ball, X_WC, 0, b.data(), nullptr);

      const Eigen::Vector2d expected = project_world(sut.lens(), X_WC, ball_W);
      const Mask m = changed_pixels(format, a, b, 640, 480);
      const char* where = to_string(format).data();
      ASSERT_GT(m.pixels, 30) << where << " " << to_string(lens.model);
      EXPECT_NEAR(m.u, expected.x(), 1.0) << where << " " << to_string(lens.model);
      EXPECT_NEAR(m.v, expected.y(), 1.0) << where << " " << to_string(lens.model);
      const Annotation* ball = find(annotations, AnnotationKind::kBall, physics::kBallObjectId);
      ASSERT_NE(ball, nullptr);
      EXPECT_NEAR(ball->u_px, expected.x(), 1e-3);
      EXPECT_NEAR(ball->v_px, expected.y(), 1e-3);
      EXPECT_TRUE(ball->in_fov);
      EXPECT_TRUE(ball->visible);
      if (format == PixelFormat::kRgb24) {
        EXPECT_EQ(static_cast<int>(ball->visible_px), m.pixels);
      }
    }
  }
}

TEST(RendererTest, FramesAreDeterministicAndIndependentOfTheThreadCount) {
  const LensConfig lens = default_head_camera().lens;
  Renderer one(lens, 640, 480, PixelFormat::kBayerGrbg, 1);
  Renderer three(lens, 640, 480, PixelFormat::kBayerGrbg, 3);
  const auto scene = make_demo_scene(6);
  const Eigen::Isometry3d X_WC = look_at({-1.0, 0.3, 0.5}, {1.0, 0.0, 0.0});
  std::vector<uint8_t> a(frame_bytes(PixelFormat::kBayerGrbg, 640, 480));
  std::vector<uint8_t> b(a.size());
  std::vector<uint8_t> c(a.size());

  one.render(scene, X_WC, 7, a.data(), nullptr);
  one.render(scene, X_WC, 8, b.data(), nullptr);
  three.render(scene, X_WC, 7, c.data(), nullptr);

  EXPECT_EQ(a, b);
  EXPECT_EQ(a, c);
}

TEST(RendererTest, FieldFeaturesAreAnnotatedAtTheirProjectionAndHiddenUnderARobot) {
  const LensConfig lens = pinhole_from_hfov(640, 480, 90.0);
  Renderer sut(lens, 640, 480, PixelFormat::kYuyv);
  physics::SceneView scene = make_demo_scene(0);
  Eigen::Isometry3d X_WR = Eigen::Isometry3d::Identity();
  // On the line of sight to the yellow-side penalty mark (1.2, 0): at 0.4 m height it passes x = 1.104.
  X_WR.translation() = Eigen::Vector3d(1.104, 0.0, 0.0);
  const auto robot = robot_placeholder(physics::kFirstRobotObjectId, physics::kTeamCyan, X_WR);
  scene.shapes.insert(scene.shapes.end(), robot.begin(), robot.end());
  const Eigen::Isometry3d X_WC = overhead(5.0);
  std::vector<uint8_t> img(frame_bytes(PixelFormat::kYuyv, 640, 480));
  FrameAnnotations annotations;

  sut.render(scene, X_WC, 0, img.data(), &annotations);

  const auto features = physics::field_features();
  int features_seen = 0;
  for (uint32_t i = 0; i < annotations.count; ++i) {
    const Annotation& a = annotations.items[i];
    if (a.kind != AnnotationKind::kLineL && a.kind != AnnotationKind::kLineT && a.kind != AnnotationKind::kLineX) {
      continue;
    }
    ++features_seen;
    const physics::FieldFeature& f = features.at(a.object_id);
    const Eigen::Vector2d expected = project_world(sut.lens(), X_WC, f.position_W);
    EXPECT_NEAR(a.u_px, expected.x(), 1e-3);
    EXPECT_NEAR(a.v_px, expected.y(), 1e-3);
    EXPECT_TRUE(a.in_fov);
    const bool under_robot = std::abs(f.position_W.x() - 1.2) < 1e-9 && f.position_W.y() == 0.0;
    EXPECT_EQ(a.visible != 0, !under_robot) << f.position_W.transpose();
  }
  EXPECT_EQ(features_seen, 18);
  const Annotation* robot_truth = find(annotations, AnnotationKind::kRobot, physics::kFirstRobotObjectId);
  ASSERT_NE(robot_truth, nullptr);
  EXPECT_TRUE(robot_truth->visible);
  EXPECT_NEAR(robot_truth->x_w_m, 1.104, 0.02);
}

TEST(RendererTest, AnnotationsWithoutPixelsAgreeOnVisibilityAndHideAnOccludedBall) {
  const LensConfig lens = pinhole_from_hfov(640, 480, 70.0);
  Renderer sut(lens, 640, 480, PixelFormat::kRgb24);
  physics::SceneView scene = make_demo_scene(0, {1.0, 0.0});
  Eigen::Isometry3d X_WR = Eigen::Isometry3d::Identity();
  X_WR.translation() = Eigen::Vector3d(0.5, 0.0, 0.0);  // between camera and ball, legs across the view
  X_WR.linear() = Eigen::AngleAxisd(0.5 * std::numbers::pi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto robot = robot_placeholder(physics::kFirstRobotObjectId, physics::kTeamMagenta, X_WR);
  scene.shapes.insert(scene.shapes.end(), robot.begin(), robot.end());
  const Eigen::Isometry3d X_WC = look_at({-0.5, 0.0, 0.1}, {1.0, 0.0, 0.03});
  std::vector<uint8_t> img(frame_bytes(PixelFormat::kRgb24, 640, 480));
  FrameAnnotations rendered;
  FrameAnnotations truth_only;

  sut.render(scene, X_WC, 0, img.data(), &rendered);
  sut.annotate(scene, X_WC, &truth_only);

  const Annotation* a = find(rendered, AnnotationKind::kBall, physics::kBallObjectId);
  const Annotation* b = find(truth_only, AnnotationKind::kBall, physics::kBallObjectId);
  ASSERT_NE(a, nullptr);
  ASSERT_NE(b, nullptr);
  EXPECT_TRUE(a->in_fov);
  EXPECT_FALSE(a->visible);
  EXPECT_EQ(a->visible_px, 0u);
  EXPECT_FALSE(b->visible);
  const Annotation* r = find(truth_only, AnnotationKind::kRobot, physics::kFirstRobotObjectId);
  ASSERT_NE(r, nullptr);
  EXPECT_TRUE(r->visible);
  EXPECT_EQ(r->visible_px, 0u);  // no pixels were rendered
}

TEST(RendererTest, NoiseChangesPixelsReproduciblyAndOffRestoresTheCleanFrame) {
  const LensConfig lens = pinhole_from_hfov(320, 240, 80.0);
  Renderer sut(lens, 320, 240, PixelFormat::kRgb24, 2);
  const auto scene = make_demo_scene(2);
  const Eigen::Isometry3d X_WC = look_at({-1.0, 0.0, 0.6}, {1.0, 0.0, 0.0});
  std::vector<uint8_t> clean(frame_bytes(PixelFormat::kRgb24, 320, 240));
  std::vector<uint8_t> noisy1(clean.size());
  std::vector<uint8_t> noisy2(clean.size());
  std::vector<uint8_t> again(clean.size());
  NoiseConfig noise;
  noise.gaussian_sigma = 4.0;
  noise.shot_noise_gain = 0.5;
  noise.seed = 42;

  sut.render(scene, X_WC, 1, clean.data(), nullptr);
  sut.set_noise(noise);
  sut.render(scene, X_WC, 1, noisy1.data(), nullptr);
  sut.render(scene, X_WC, 1, noisy2.data(), nullptr);
  sut.set_noise(NoiseConfig{});
  sut.render(scene, X_WC, 1, again.data(), nullptr);

  EXPECT_NE(clean, noisy1);
  EXPECT_EQ(noisy1, noisy2);
  EXPECT_EQ(clean, again);
}

TEST(RendererTest, AConvexHullIsDrawnByItsFacesNotItsBounds) {
  // An octahedron (vertices 0.5 m out on each axis) 1 m above the floor, seen from 5 m above: its
  // outline is the diamond |x| + |y| <= 0.5. (0.2, 0.2) lies inside it, (0.3, 0.3) inside its
  // bounding box and sphere but outside the diamond.
  std::vector<Eigen::Vector3d> points;
  for (int axis = 0; axis < 3; ++axis) {
    for (double sign : {-0.5, 0.5}) points.push_back(sign * Eigen::Vector3d::Unit(axis));
  }
  physics::SceneView scene;
  physics::VisualShape hull;
  hull.type = physics::ShapeType::kConvex;
  hull.kind = physics::ObjectKind::kRobotBody;
  hull.hull = physics::convex_hull(points);
  hull.size_m = hull.hull->half_extents;
  hull.X_WS.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  hull.colour = physics::Rgb{220, 20, 20};
  scene.shapes.push_back(hull);
  const LensConfig lens = pinhole_from_hfov(320, 240, 60.0);
  Renderer sut(lens, 320, 240, PixelFormat::kRgb24);
  const Eigen::Isometry3d X_WC = overhead(5.0);
  std::vector<uint8_t> img(frame_bytes(PixelFormat::kRgb24, 320, 240));

  sut.render(scene, X_WC, 0, img.data(), nullptr);

  const uint8_t* inside = rgb_at(img, 320, project_world(sut.lens(), X_WC, {0.2, 0.2, 1.2}));
  const uint8_t* outside = rgb_at(img, 320, project_world(sut.lens(), X_WC, {0.3, 0.3, 1.0}));
  EXPECT_GT(inside[0], inside[1] + 60);  // the hull's red, shaded
  EXPECT_LT(std::abs(outside[0] - outside[1]), 20);  // grey floor or background, not red
}

}  // namespace
}  // namespace doppel::camera
