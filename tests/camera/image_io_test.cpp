// The ground-truth JSON doppel-camera writes beside each PNG: valid JSON for any camera name, every
// header and annotation field, NaN as null. Read back with nlohmann-json, not with the writer's code.
#include "camera/image_io.h"

#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

namespace doppel::camera {
namespace {

FrameHeader header_named(const std::string& name) {
  FrameHeader h;
  std::strncpy(h.camera_name, name.c_str(), sizeof(h.camera_name) - 1);
  h.sequence = 42;
  h.sim_time_ns = 1'500'000'000;
  h.format = static_cast<uint32_t>(PixelFormat::kYuyv);
  h.width_px = 640;
  h.height_px = 480;
  h.position_w_m[2] = 0.45;
  h.lens.fx_px = 320.5;
  h.frames_dropped = 3;
  return h;
}

TEST(GroundTruthJson, ANameWithQuotesAndBackslashesStaysValidJson) {
  const std::string name = R"(he said "hi" \ C:\cam\n)";
  const FrameHeader h = header_named(name);

  const nlohmann::json sut = nlohmann::json::parse(frame_ground_truth_json(h, nullptr));

  EXPECT_EQ(sut.at("camera").get<std::string>(), name);
  EXPECT_EQ(sut.at("sequence").get<uint64_t>(), 42u);
  EXPECT_EQ(sut.at("sim_time_ns").get<int64_t>(), 1'500'000'000);
  EXPECT_EQ(sut.at("format").get<std::string>(), "yuyv");
  EXPECT_EQ(sut.at("width_px").get<int>(), 640);
  EXPECT_DOUBLE_EQ(sut.at("camera_position_w_m").at(2).get<double>(), 0.45);
  EXPECT_DOUBLE_EQ(sut.at("camera_orientation_w_wxyz").at(0).get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(sut.at("lens").at("fx_px").get<double>(), 320.5);
  EXPECT_EQ(sut.at("frames_dropped").get<uint64_t>(), 3u);
  EXPECT_TRUE(sut.at("annotations").is_array());
  EXPECT_TRUE(sut.at("annotations").empty());
}

TEST(GroundTruthJson, AnnotationsCarryEveryFieldAndNanAsNull) {
  const FrameHeader h = header_named("HEAD_CAMERA");
  FrameAnnotations annotations;
  annotations.count = 1;
  Annotation& ball = annotations.items[0];
  ball.kind = AnnotationKind::kBall;
  ball.object_id = 7;
  ball.in_fov = 1;
  ball.visible = 1;
  ball.visible_px = 120;
  ball.u_px = 300.5f;
  ball.v_px = std::numeric_limits<float>::quiet_NaN();
  ball.bbox_max_u = 310.0f;
  ball.distance_m = 1.25f;
  ball.y_w_m = -0.5f;

  const nlohmann::json sut = nlohmann::json::parse(frame_ground_truth_json(h, &annotations));

  ASSERT_EQ(sut.at("annotations").size(), 1u);
  const nlohmann::json& a = sut.at("annotations").at(0);
  EXPECT_EQ(a.at("kind").get<std::string>(), to_string(AnnotationKind::kBall));
  EXPECT_EQ(a.at("object_id").get<int>(), 7);
  EXPECT_TRUE(a.at("in_fov").get<bool>());
  EXPECT_TRUE(a.at("visible").get<bool>());
  EXPECT_EQ(a.at("visible_px").get<int>(), 120);
  EXPECT_DOUBLE_EQ(a.at("u_px").get<double>(), 300.5);
  EXPECT_TRUE(a.at("v_px").is_null());
  EXPECT_DOUBLE_EQ(a.at("bbox").at(2).get<double>(), 310.0);
  EXPECT_DOUBLE_EQ(a.at("distance_m").get<double>(), 1.25);
  EXPECT_DOUBLE_EQ(a.at("position_w_m").at(1).get<double>(), -0.5);
  EXPECT_DOUBLE_EQ(a.at("heading_rad").get<double>(), 0.0);
}

TEST(GroundTruthJson, ANameThatIsNotUtf8IsStillWritten) {
  const FrameHeader h = header_named("cam\xff\xfe");

  const nlohmann::json sut = nlohmann::json::parse(frame_ground_truth_json(h, nullptr));

  EXPECT_EQ(sut.at("camera").get<std::string>().substr(0, 3), "cam");
}

}  // namespace
}  // namespace doppel::camera
