// The gateway's side of the world-model sensor: doppel's options for it and a session file's extra
// balls, read with errors that name file, line and field.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "gateway/options.h"
#include "gateway/robot_config.h"

namespace doppel::gateway {
namespace {

Options parse(std::vector<const char*> args) {
  args.insert(args.begin(), "doppel");
  return parse_options(static_cast<int>(args.size()), args.data());
}

std::string error_of(const std::string& session) {
  try {
    parse_session(session, "sessions/balls.textproto");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(WorldModelOptions, OffByDefaultOnWithAnyOfItsOptions) {
  const Options plain = parse({});
  EXPECT_FALSE(plain.truth.world_model);
  EXPECT_EQ(plain.truth.udp_port, 7600);
  EXPECT_EQ(plain.truth.udp_address, "127.0.0.1");
  EXPECT_TRUE(plain.truth.iceoryx);
  EXPECT_TRUE(parse({"--world-model"}).truth.world_model);
  const Options fov = parse({"--world-model-fov", "60", "--world-model-nearest-ball", "--world-model-rate", "50",
                             "--world-model-range", "3", "--truth-udp-port", "9000", "--truth-udp-address",
                             "192.168.1.20", "--no-truth-iceoryx"});
  EXPECT_TRUE(fov.truth.world_model);
  EXPECT_EQ(fov.truth.world_model_settings.fov_deg, 60.0);
  EXPECT_TRUE(fov.truth.world_model_settings.nearest_ball_only);
  EXPECT_EQ(fov.truth.world_model_settings.rate_hz, 50.0);
  EXPECT_EQ(fov.truth.world_model_settings.max_range_m, 3.0);
  EXPECT_EQ(fov.truth.udp_port, 9000);
  EXPECT_EQ(fov.truth.udp_address, "192.168.1.20");
  EXPECT_FALSE(fov.truth.iceoryx);
}

TEST(WorldModelOptions, BadValuesAreRejectedWithTheirName) {
  for (const std::vector<const char*>& args : std::vector<std::vector<const char*>>{
           {"--world-model-fov", "180"}, {"--world-model-rate", "0"}, {"--world-model-range", "-1"},
           {"--truth-udp-port", "0"}, {"--truth-udp-address", "localhost.example"}}) {
    try {
      parse(args);
      ADD_FAILURE() << args[0] << " " << args[1] << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(args[0]), std::string::npos) << e.what();
    }
  }
}

TEST(SessionBalls, ExtraBallsInFileOrder) {
  const SessionConfig session = parse_session(
      "ball { position_m { x: -1.5 y: -0.8 } }\nball { position_m { x: 1 y: 2 z: 7 } }", "sessions/balls.textproto");
  ASSERT_EQ(session.extra_balls.size(), 2u);
  EXPECT_EQ(session.extra_balls[0], Eigen::Vector2d(-1.5, -0.8));
  EXPECT_EQ(session.extra_balls[1], Eigen::Vector2d(1.0, 2.0));
  EXPECT_TRUE(parse_session("", "empty.textproto").extra_balls.empty());
}

TEST(SessionBalls, BadBallsNameFileLineAndField) {
  const std::string missing = error_of("ball { }");
  EXPECT_EQ(missing.rfind("sessions/balls.textproto:1:", 0), 0u) << missing;
  EXPECT_NE(missing.find("position_m"), std::string::npos) << missing;
  const std::string off = error_of("\nball { position_m { x: 4.0 y: 0 } }");
  EXPECT_EQ(off.rfind("sessions/balls.textproto:2:", 0), 0u) << off;
  EXPECT_NE(off.find("off the carpet"), std::string::npos) << off;
  const std::string nan = error_of("ball { position_m { x: nan } }");
  EXPECT_NE(nan.find("must be finite"), std::string::npos) << nan;
  std::string eight;
  for (int i = 0; i < 8; ++i) eight += "ball { position_m { x: 0.1 } }\n";
  const std::string many = error_of(eight);
  EXPECT_EQ(many.rfind("sessions/balls.textproto:8:", 0), 0u) << many;
  EXPECT_NE(many.find("at most 7"), std::string::npos) << many;
}

}  // namespace
}  // namespace doppel::gateway
