#include "physics/robot_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>
#include <string>

#include "body/motor_params.h"

namespace doppel::physics {
namespace {

using ::testing::HasSubstr;

constexpr double kDeg = std::numbers::pi / 180.0;

std::string robot_path(const std::string& name) { return std::string(DOPPEL_ROBOTS_DIR) + "/" + name + ".textproto"; }

// A two-servo arm on one bus; `figure` replaces the body part.
std::string arm_text(const std::string& figure) {
  return R"(name: "arm"
bus {
  name: "b" baud_bps: 1000000 protocol: PROTOCOL_1
  device { id: 1 model: "RX-64" name: "J1" }
  device { id: 2 model: "RX-28" name: "J2" }
  device { id: 100 model: "FUMANOID-IMU" name: "IMU" }
}
)" + figure;
}

const char* kGoodFigure = R"(figure {
  body { name: "base" shape { box { size_m { x: 0.1 y: 0.1 z: 0.1 } } } mass_kg: 1 }
  body { name: "upper" pose { position_m { z: 0.2 } } shape { box { size_m { x: 0.05 y: 0.05 z: 0.2 } } } mass_kg: 0.5 }
  body { name: "lower" pose { position_m { z: 0.4 } } shape { box { size_m { x: 0.05 y: 0.05 z: 0.2 } } } mass_kg: 0.3 }
  link { name: "J1" type: LINK_REVOLUTE parent: "base" child: "upper" anchor_m { z: 0.1 } axis { y: 1 }
         motor { bus: 0 id: 1 } }
  link { name: "J2" type: LINK_REVOLUTE parent: "upper" child: "lower" anchor_m { z: 0.3 } axis { y: 1 }
         lower_deg: -90 upper_deg: 90 motor { bus: 0 id: 2 } }
})";

std::string error_of(const std::string& text) {
  try {
    const proto::RobotFile file = proto::RobotFile::parse(text, "bad.textproto");
    validate_body(file, doppel::body::motor_catalog());
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no error";
}

// Line (1-based) of the first occurrence of `needle` in `text`.
int line_of(const std::string& text, const std::string& needle) {
  const size_t at = text.find(needle);
  if (at == std::string::npos) {
    ADD_FAILURE() << "'" << needle << "' not in the test text";
    return 0;
  }
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

TEST(RobotModelTest, DefaultHumanoidHas22Bodies21ServosOfTheThesisModels) {
  const proto::RobotFile file = proto::RobotFile::load(robot_path("fumanoid-2011"));

  const RobotModel sut = compile_robot(file, doppel::body::motor_catalog());

  EXPECT_EQ(sut.bodies.size(), 22U);
  EXPECT_EQ(sut.links.size(), 21U);
  ASSERT_EQ(sut.motors.size(), 21U);
  std::map<std::string, int> per_model;
  for (const MotorModel& m : sut.motors) {
    ++per_model[m.model];
  }
  EXPECT_EQ(per_model["RX-64"], 14);  // thesis section 4.2.1.2
  EXPECT_EQ(per_model["RX-28"], 7);
  // Every servo of the bus part is driven by exactly one link (IDs 1..21).
  std::map<int, int> per_id;
  for (const MotorModel& m : sut.motors) {
    ++per_id[m.id];
  }
  for (int id = 1; id <= 21; ++id) {
    EXPECT_EQ(per_id[id], 1) << "servo " << id;
  }
  EXPECT_GT(sut.mass_kg, 3.0);  // a 60 cm KidSize robot of 2011: a few kilograms
  EXPECT_LT(sut.mass_kg, 6.0);
  EXPECT_EQ(sut.imus.size(), 1U);
  EXPECT_EQ(sut.feet.size(), 2U);
  EXPECT_EQ(sut.cameras.size(), 1U);
}

TEST(RobotModelTest, DefaultHumanoidIsAbout60CmTallAtTheDesignPose) {
  const RobotModel sut = compile_robot(proto::RobotFile::load(robot_path("fumanoid-2011")), doppel::body::motor_catalog());

  double top = -1.0, bottom = 1.0;
  for (const BodyModel& body : sut.bodies) {
    for (const ShapeSpec& s : body.shapes) {
      const Eigen::Isometry3d X = body.X_RB * s.X_BS;
      for (int corner = 0; corner < 8; ++corner) {
        const Eigen::Vector3d half = 0.5 * s.size_m;
        const Eigen::Vector3d p(corner & 1 ? half.x() : -half.x(), corner & 2 ? half.y() : -half.y(),
                                corner & 4 ? half.z() : -half.z());
        top = std::max(top, (X * p).z());
        bottom = std::min(bottom, (X * p).z());
      }
    }
  }

  EXPECT_NEAR(bottom, 0.0, 1e-9);
  EXPECT_NEAR(top, 0.60, 0.05);
}

TEST(RobotModelTest, PitchModelHas10Bodies9MotorsAllAboutTheYAxis) {
  const RobotModel sut = compile_robot(proto::RobotFile::load(robot_path("fumanoid-pitch")), doppel::body::motor_catalog());

  EXPECT_EQ(sut.bodies.size(), 10U);  // thesis figure 36
  EXPECT_EQ(sut.motors.size(), 9U);
  for (const LinkModel& link : sut.links) {
    EXPECT_NEAR(std::abs(link.axis_R.y()), 1.0, 1e-12) << link.name;
  }
}

TEST(RobotModelTest, CompoundBodyHasCentreOfMassAndParallelAxisInertia) {
  const std::string text = arm_text(R"(figure {
  body { name: "dumbbell" pose { position_m { z: 1 } }
         shape { sphere { radius_m: 0.1 } pose { position_m { x: 0.5 } } }
         shape { sphere { radius_m: 0.1 } pose { position_m { x: -0.3 } } }
         mass_kg: 2 }
})");

  const RobotModel sut = compile_robot(proto::RobotFile::parse(text, "dumbbell.textproto"), doppel::body::motor_catalog());

  // Two equal spheres: centre of mass midway (x = 0.1), each 1 kg at 0.4 m from it.
  const BodyModel& body = sut.bodies[0];
  EXPECT_NEAR(body.X_RB.translation().x(), 0.1, 1e-12);
  EXPECT_NEAR(body.X_RB.translation().z(), 1.0, 1e-12);
  const double own = 0.4 * 1.0 * 0.01;                // 2/5 m r^2 per sphere
  const double lateral = 2.0 * (own + 1.0 * 0.16);    // + m d^2
  const Eigen::Vector3d expected(2.0 * own, lateral, lateral);
  const Eigen::Vector3d world_inertia = (body.X_RB.linear() * body.inertia_kg_m2.asDiagonal() * body.X_RB.linear().transpose()).diagonal();
  EXPECT_NEAR(world_inertia.x(), expected.x(), 1e-12);
  EXPECT_NEAR(world_inertia.y(), expected.y(), 1e-12);
  EXPECT_NEAR(world_inertia.z(), expected.z(), 1e-12);
}

TEST(RobotModelTest, DensityGivesMassFromVolume) {
  const std::string text = arm_text(R"(figure {
  body { name: "block" shape { box { size_m { x: 0.1 y: 0.2 z: 0.5 } } } density_kg_m3: 1000 }
})");

  const RobotModel sut = compile_robot(proto::RobotFile::parse(text, "block.textproto"), doppel::body::motor_catalog());

  EXPECT_NEAR(sut.bodies[0].mass_kg, 10.0, 1e-9);
}

TEST(RobotModelTest, BodyPosesFollowTheLinkPositions) {
  const RobotModel sut = compile_robot(proto::RobotFile::parse(arm_text(kGoodFigure), "arm.textproto"), doppel::body::motor_catalog());

  const auto X = body_poses(sut, {90.0 * kDeg, 0.0});

  // J1 about +y at z = 0.1 turns the upper body (centre 0.1 above the joint) to +x.
  EXPECT_NEAR(X[1].translation().x(), 0.1, 1e-12);
  EXPECT_NEAR(X[1].translation().z(), 0.1, 1e-12);
  EXPECT_NEAR(X[2].translation().x(), 0.3, 1e-12);
}

TEST(RobotModelTest, MotorKeepsItsServoIdAndDirection) {
  const RobotModel sut = compile_robot(proto::RobotFile::load(robot_path("fumanoid-2011")), doppel::body::motor_catalog());

  for (const MotorModel& m : sut.motors) {
    const std::string& name = sut.links[static_cast<size_t>(m.link)].name;
    EXPECT_EQ(m.direction, name.find("RIGHT") != std::string::npos ? -1.0 : 1.0) << name;
  }
}

struct BadFile {
  const char* what;       // test label
  const char* figure;     // the body part
  const char* at;         // text whose line the error must name
  const char* message;    // part of the message
};

class RobotModelErrorTest : public ::testing::TestWithParam<BadFile> {};

TEST_P(RobotModelErrorTest, NamesFileLineAndField) {
  const BadFile& bad = GetParam();
  const std::string text = arm_text(bad.figure);

  const std::string error = error_of(text);

  EXPECT_THAT(error, HasSubstr("bad.textproto:" + std::to_string(line_of(text, bad.at)) + ":"));
  EXPECT_THAT(error, HasSubstr(bad.message));
}

INSTANTIATE_TEST_SUITE_P(
    Errors, RobotModelErrorTest,
    ::testing::Values(
        BadFile{"UnknownBody", R"(figure {
  body { name: "base" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "arm" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "J1" type: LINK_REVOLUTE parent: "base" child: "amr" axis { z: 1 } }
})",
                "child: \"amr\"", "Link.child: unknown body 'amr'"},
        BadFile{"LoopClosingLink", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "c" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "ab" type: LINK_FIXED parent: "a" child: "b" }
  link { name: "bc" type: LINK_FIXED parent: "b" child: "c" }
  link { name: "ac" type: LINK_FIXED parent: "a" child: "c" }
})",
                "child: \"c\" }\n}", "link would close a loop"},
        BadFile{"MotorIdUsedTwice", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "c" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "ab" type: LINK_REVOLUTE parent: "a" child: "b" axis { z: 1 } motor { bus: 0 id: 1 } }
  link { name: "bc" type: LINK_REVOLUTE parent: "b" child: "c" axis { z: 1 } motor { bus: 0 id: 1 } }
})",
                "\"c\" axis { z: 1 } motor { bus: 0 id: 1", "Motor.id: motor ID 1 on bus 0 is used twice"},
        BadFile{"MissingMass", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } }
  link { name: "ab" type: LINK_FIXED parent: "a" child: "b" }
})",
                "body { name: \"b\"", "Body.mass_kg: missing mass"},
        BadFile{"DisconnectedBody", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
})",
                "body { name: \"b\"", "is not connected"},
        BadFile{"MotorOnMissingDevice", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "ab" type: LINK_REVOLUTE parent: "a" child: "b" axis { z: 1 } motor { bus: 0 id: 7 } }
})",
                "motor { bus: 0 id: 7", "Motor.id: no device with ID 7 on bus 0"},
        BadFile{"MotorOnAnImu", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "ab" type: LINK_REVOLUTE parent: "a" child: "b" axis { z: 1 } motor { bus: 0 id: 100 } }
})",
                "motor { bus: 0 id: 100", "not a servo"},
        BadFile{"UnknownMaterial", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 material: "rubber" }
})",
                "material: \"rubber\"", "Body.material: unknown material 'rubber'"},
        BadFile{"ZeroBoxSize", R"(figure {
  body { name: "a" shape { box { size_m { x: 0.1 y: 0 z: 0.1 } } } mass_kg: 1 }
})",
                "size_m", "Box.size_m: must be > 0"},
        BadFile{"NoAxis", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "ab" type: LINK_REVOLUTE parent: "a" child: "b" }
})",
                "link { name: \"ab\"", "non-zero axis"},
        BadFile{"InitialOutsideLimits", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  body { name: "b" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  link { name: "ab" type: LINK_REVOLUTE parent: "a" child: "b" axis { z: 1 }
         lower_deg: -10 upper_deg: 10 initial_deg: 20 }
})",
                "initial_deg: 20", "outside the link's limits"},
        BadFile{"FootWithThreeCells", R"(figure {
  body { name: "a" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }
  foot { name: "F" body: "a" bus: 0 id: 100 cell_m { x: 1 } cell_m { x: 2 } cell_m { x: 3 } }
})",
                "cell_m { x: 3 }", "exactly four load cells"},
        BadFile{"NoFigure", "", "name: \"arm\"", "has no body"}),
    [](const ::testing::TestParamInfo<BadFile>& param) { return std::string(param.param.what); });

TEST(RobotModelTest, ShippedRobotsPassValidation) {
  for (const char* name : {"fumanoid-2011", "fumanoid-pitch", "op3"}) {
    EXPECT_NO_THROW(validate_body(proto::RobotFile::load(robot_path(name)), doppel::body::motor_catalog())) << name;
  }
}

}  // namespace
}  // namespace doppel::physics
