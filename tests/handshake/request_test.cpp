// check_add_robot: every field of an add_robot request reaches contract::RobotRequest, and every bad
// one is refused naming its proto field path (limits: libs/camera/src/camera_config.cpp, libs/camera/src/noise.cpp,
// control/world_model_settings.h).
#include "handshake/request.h"

#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <limits>

namespace doppel::handshake {
namespace {

wire::AddRobot parse(const std::string& text) {
  wire::AddRobot m;
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &m)) << text;
  return m;
}

contract::Refusal refusal(const std::string& text) {
  auto checked = check_add_robot(parse(text));
  EXPECT_TRUE(std::holds_alternative<contract::Refusal>(checked)) << text;
  return std::holds_alternative<contract::Refusal>(checked) ? std::get<contract::Refusal>(checked) : contract::Refusal{};
}

TEST(HandshakeRequest, EveryFieldReachesTheHostRequest) {
  const auto checked = check_add_robot(parse(R"(
      robot: "op3" x_m: 1.5 y_m: -2 yaw_rad: 3.1 team: 1
      camera { name: "head" width_px: 320 height_px: 240 fps: 30 format: "bayer_rggb" lens: "pinhole"
               hfov_deg: 90 noise { gaussian_sigma: 2.5 salt_pepper_fraction: 0.01 seed: 7 } }
      camera { name: "chest" }
      world_model { rate_hz: 10 fov_deg: 120 max_range_m: 6 nearest_ball_only: true position_sigma_m: 0.05
                    angle_sigma_rad: 0.02 dropout: 0.1 latency_s: 0.05 seed: 3 }
      sensor_levels: true)"));
  ASSERT_TRUE(std::holds_alternative<contract::RobotRequest>(checked));
  const auto& r = std::get<contract::RobotRequest>(checked);
  EXPECT_EQ(r.robot, "op3");
  EXPECT_TRUE(r.description.empty());
  EXPECT_EQ(r.x_m, 1.5);
  EXPECT_EQ(r.y_m, -2.0);
  EXPECT_EQ(r.yaw_rad, 3.1);
  EXPECT_EQ(r.team, 1u);
  ASSERT_EQ(r.cameras.size(), 2u);
  const contract::CameraRequest& head = r.cameras[0];
  EXPECT_EQ(head.name, "head");
  EXPECT_EQ(head.width_px, 320u);
  EXPECT_EQ(head.height_px, 240u);
  EXPECT_EQ(head.fps, 30.0);
  EXPECT_EQ(head.format, "bayer_rggb");
  EXPECT_EQ(head.lens, "pinhole");
  EXPECT_EQ(head.hfov_deg, 90.0);
  EXPECT_EQ(head.noise_gaussian_sigma, 2.5);
  EXPECT_EQ(head.noise_salt_pepper_fraction, 0.01);
  EXPECT_EQ(head.noise_seed, 7u);
  const contract::CameraRequest& chest = r.cameras[1];
  EXPECT_EQ(chest.name, "chest");
  EXPECT_FALSE(chest.width_px || chest.height_px || chest.fps || chest.format || chest.lens || chest.hfov_deg ||
               chest.noise_gaussian_sigma || chest.noise_salt_pepper_fraction || chest.noise_seed);
  EXPECT_FALSE(r.cameras_off);
  ASSERT_TRUE(r.world_model);
  EXPECT_TRUE(r.world_model->enabled);
  EXPECT_EQ(r.world_model->rate_hz, 10.0);
  EXPECT_EQ(r.world_model->fov_deg, 120.0);
  EXPECT_EQ(r.world_model->max_range_m, 6.0);
  EXPECT_TRUE(r.world_model->nearest_ball_only);
  EXPECT_EQ(r.world_model->position_sigma_m, 0.05);
  EXPECT_EQ(r.world_model->angle_sigma_rad, 0.02);
  EXPECT_EQ(r.world_model->dropout, 0.1);
  EXPECT_EQ(r.world_model->latency_s, 0.05);
  EXPECT_EQ(r.world_model->seed, 3u);
  EXPECT_TRUE(r.sensor_levels);
}

TEST(HandshakeRequest, UnsetFieldsStayUnset) {
  const auto checked = check_add_robot(parse(R"(description: "name: \"x\"" world_model {})"));
  ASSERT_TRUE(std::holds_alternative<contract::RobotRequest>(checked));
  const auto& r = std::get<contract::RobotRequest>(checked);
  EXPECT_TRUE(r.robot.empty());
  EXPECT_EQ(r.description, "name: \"x\"");
  EXPECT_FALSE(r.x_m || r.y_m || r.yaw_rad || r.team);
  EXPECT_TRUE(r.cameras.empty());
  EXPECT_FALSE(r.sensor_levels);
  ASSERT_TRUE(r.world_model);  // present: the robot gets one, with the documented defaults
  const contract::WorldModelSettings defaults;
  EXPECT_EQ(r.world_model->rate_hz, defaults.rate_hz);
  EXPECT_EQ(r.world_model->fov_deg, 0.0);
  const auto plain = check_add_robot(parse(R"(robot: "op3")"));
  ASSERT_TRUE(std::holds_alternative<contract::RobotRequest>(plain));
  EXPECT_FALSE(std::get<contract::RobotRequest>(plain).world_model);  // absent: no world-model sensor
}

struct Bad {
  const char* request;
  const char* field;
  const char* says;  // part of the message
};

class HandshakeBadRequest : public ::testing::TestWithParam<Bad> {};

TEST_P(HandshakeBadRequest, IsRefusedNamingItsField) {
  const contract::Refusal r = refusal(GetParam().request);
  EXPECT_EQ(r.field, GetParam().field) << r.message;
  EXPECT_NE(r.message.find(GetParam().says), std::string::npos) << r.message;
}

INSTANTIATE_TEST_SUITE_P(
    Fields, HandshakeBadRequest,
    ::testing::Values(
        Bad{"", "add_robot.robot", "name a robot"},
        Bad{R"(robot: "op3" description: "name: \"x\"")", "add_robot.robot", "not both"},
        Bad{R"(robot: "op3" x_m: 100.5)", "add_robot.x_m", "[-100, 100]"},
        Bad{R"(robot: "op3" y_m: -101)", "add_robot.y_m", "got -101"},
        Bad{R"(robot: "op3" yaw_rad: 7)", "add_robot.yaw_rad", "got 7"},
        Bad{R"(robot: "op3" x_m: nan)", "add_robot.x_m", "got nan"},
        Bad{R"(robot: "op3" team: 2)", "add_robot.team", "0 or 1"},
        Bad{R"(robot: "op3" cameras_off: true camera { name: "head" })", "add_robot.cameras_off", "lists 1"},
        Bad{R"(robot: "op3" camera { name: "" })", "add_robot.camera[0].name", "camera mount"},
        Bad{R"(robot: "op3" camera { name: "a b" })", "add_robot.camera[0].name", "1..63"},
        Bad{R"(robot: "op3" camera { name: "head" } camera { name: "head" })", "add_robot.camera[1].name", "twice"},
        Bad{R"(robot: "op3" camera { name: "head" } camera { name: "b" width_px: 8193 })", "add_robot.camera[1].width_px", "2..8192"},
        Bad{R"(robot: "op3" camera { name: "head" width_px: 1 })", "add_robot.camera[0].width_px", "got 1"},
        Bad{R"(robot: "op3" camera { name: "head" height_px: 0 })", "add_robot.camera[0].height_px", "2..8192"},
        Bad{R"(robot: "op3" camera { name: "head" width_px: 321 format: "yuyv" })", "add_robot.camera[0].width_px", "even"},
        Bad{R"(robot: "op3" camera { name: "head" fps: 0 })", "add_robot.camera[0].fps", "(0, 1000]"},
        Bad{R"(robot: "op3" camera { name: "head" fps: 1000.5 })", "add_robot.camera[0].fps", "(0, 1000]"},
        Bad{R"(robot: "op3" camera { name: "head" format: "mjpeg" })", "add_robot.camera[0].format", "bayer_gbrg"},
        Bad{R"(robot: "op3" camera { name: "head" lens: "fisheye" })", "add_robot.camera[0].lens", "stereographic"},
        Bad{R"(robot: "op3" camera { name: "head" hfov_deg: 180 })", "add_robot.camera[0].hfov_deg", "(0, 180)"},
        Bad{R"(robot: "op3" camera { name: "head" lens: "pinhole" hfov_deg: 170 })", "add_robot.camera[0].hfov_deg", "(0, 170)"},
        Bad{R"(robot: "op3" camera { name: "head" noise { gaussian_sigma: 256 } })", "add_robot.camera[0].noise.gaussian_sigma", "[0, 255]"},
        Bad{R"(robot: "op3" camera { name: "head" noise { salt_pepper_fraction: -0.1 } })", "add_robot.camera[0].noise.salt_pepper_fraction", "[0, 1]"},
        Bad{R"(robot: "op3" world_model { rate_hz: 0 })", "add_robot.world_model.rate_hz", "(0, 1000]"},
        Bad{R"(robot: "op3" world_model { fov_deg: 180 })", "add_robot.world_model.fov_deg", "(0, 180)"},
        Bad{R"(robot: "op3" world_model { max_range_m: -1 })", "add_robot.world_model.max_range_m", "got -1"},
        Bad{R"(robot: "op3" world_model { position_sigma_m: -0.1 })", "add_robot.world_model.position_sigma_m", "[0"},
        Bad{R"(robot: "op3" world_model { angle_sigma_rad: inf })", "add_robot.world_model.angle_sigma_rad", "got inf"},
        Bad{R"(robot: "op3" world_model { dropout: 1 })", "add_robot.world_model.dropout", "[0, 1)"},
        Bad{R"(robot: "op3" world_model { latency_s: 1.5 })", "add_robot.world_model.latency_s", "[0, 1]"}),
    [](const ::testing::TestParamInfo<Bad>& param) {
      std::string name = std::to_string(param.index) + "_" + param.param.field;
      for (char& ch : name) {
        ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
      }
      return name;
    });

TEST(HandshakeRequest, TheFirstBadFieldIsTheOneNamed) {
  const contract::Refusal r = refusal(R"(robot: "op3" team: 5 camera { name: "head" width_px: 1 })");
  EXPECT_EQ(r.field, "add_robot.team");
}

TEST(HandshakeRequest, ARobotNameWithANulOrLongerThanAPathIsRefused) {
  wire::AddRobot m;
  m.set_robot(std::string("op3\0x", 5));
  EXPECT_EQ(std::get<contract::Refusal>(check_add_robot(m)).field, "add_robot.robot");
  m.set_robot(std::string(4097, 'a'));
  EXPECT_EQ(std::get<contract::Refusal>(check_add_robot(m)).field, "add_robot.robot");
}

TEST(HandshakeRequest, HostFieldNamesBecomeProtoPaths) {
  EXPECT_EQ(proto_field_path(""), "add_robot");
  EXPECT_EQ(proto_field_path("robot"), "add_robot.robot");
  EXPECT_EQ(proto_field_path("description"), "add_robot.description");
  EXPECT_EQ(proto_field_path("cameras"), "add_robot.camera");
  EXPECT_EQ(proto_field_path("cameras[0].name"), "add_robot.camera[0].name");
  EXPECT_EQ(proto_field_path("cameras[12].width_px"), "add_robot.camera[12].width_px");
  EXPECT_EQ(proto_field_path("cameras[1].noise_gaussian_sigma"), "add_robot.camera[1].noise.gaussian_sigma");
  EXPECT_EQ(proto_field_path("cameras[1].noise_seed"), "add_robot.camera[1].noise.seed");
  EXPECT_EQ(proto_field_path("world_model.fov_deg"), "add_robot.world_model.fov_deg");
  EXPECT_EQ(proto_field_path("cameras_off"), "add_robot.cameras_off");
}

TEST(HandshakeRequest, ToWireCarriesEveryLink) {
  const wire::Robot r = to_wire(contract::RobotAdded{
      3, "op3", {{"bus", "ttyDXL0", "/run/doppel/robot3/ttyDXL0"}, {"world_model", "wm", "udp:127.0.0.1:7600"}}});
  EXPECT_EQ(r.robot(), 3u);
  EXPECT_EQ(r.name(), "op3");
  EXPECT_TRUE(r.token().empty());
  ASSERT_EQ(r.link_size(), 2);
  EXPECT_EQ(r.link(0).kind(), "bus");
  EXPECT_EQ(r.link(0).name(), "ttyDXL0");
  EXPECT_EQ(r.link(0).location(), "/run/doppel/robot3/ttyDXL0");
  EXPECT_EQ(r.link(1).location(), "udp:127.0.0.1:7600");
}

}  // namespace
}  // namespace doppel::handshake
