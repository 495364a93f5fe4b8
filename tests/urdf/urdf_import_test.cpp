// URDF import (urdf/): the test biped (data/biped.urdf, meshes written by data/make_meshes.py)
// maps to the figure its URDF describes, and every kind of bad input is refused naming the URDF
// file, the element and the robot file's line. Expected values come from the URDF's numbers and
// the mesh geometry, worked out in the comments.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "body/motor_params.h"
#include "physics/robot_model.h"
#include "urdf/urdf_import.h"

namespace doppel::urdf {
namespace {

const std::string kData = DOPPEL_URDF_TEST_DATA;
constexpr double kDeg = std::numbers::pi / 180.0;

std::string biped_text() {
  std::ifstream in(kData + "/test-biped.textproto");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The biped's robot file with `from` replaced by `to` (which must occur).
std::string biped_with(const std::string& from, const std::string& to) {
  std::string text = biped_text();
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

std::string error_of(const std::string& text) {
  try {
    proto::RobotFile file = parse_robot_file(text, kData + "/robot.textproto");
    (void)physics::compile_robot(file, body::motor_catalog());
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

// A robot file around `urdf_file` with no joint map.
std::string single(const std::string& urdf_file) {
  return "name: \"r\"\nbus { baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: \"RX-64\" } }\n"
         "figure {\n  urdf { file: \"" + urdf_file + "\" }\n}\n";
}

const proto::Body& body_named(const proto::Figure& figure, const std::string& name) {
  for (const proto::Body& b : figure.body()) {
    if (b.name() == name) return b;
  }
  ADD_FAILURE() << "no body " << name;
  return figure.body(0);
}

Eigen::Vector3d v(const proto::Vector3& p) { return {p.x(), p.y(), p.z()}; }

TEST(UrdfImport, EveryMassiveLinkBecomesABodyAtItsDesignPose) {
  const proto::RobotFile file = load_robot_file(kData + "/test-biped.textproto");
  const proto::Figure& figure = file.description().figure();

  // imu_link has no mass: a frame of the trunk, not a body.
  ASSERT_EQ(figure.body_size(), 7);
  EXPECT_EQ(figure.body(0).name(), "trunk");
  // Joint origins chain from the trunk: hip at (0, +-0.05, -0.06), knee 0.12 and ankle 0.12 below.
  EXPECT_TRUE(v(body_named(figure, "l_thigh").pose().position_m()).isApprox(Eigen::Vector3d(0, 0.05, -0.06)));
  EXPECT_TRUE(v(body_named(figure, "l_shin").pose().position_m()).isApprox(Eigen::Vector3d(0, 0.05, -0.18)));
  EXPECT_TRUE(v(body_named(figure, "r_foot").pose().position_m()).isApprox(Eigen::Vector3d(0, -0.05, -0.30)));
  const proto::Body& foot = body_named(figure, "l_foot");
  EXPECT_DOUBLE_EQ(foot.inertial().mass_kg(), 0.2);
  EXPECT_DOUBLE_EQ(foot.inertial().origin().position_m().z(), -0.02);
  EXPECT_DOUBLE_EQ(foot.inertial().iyy_kg_m2(), 0.000247);
  EXPECT_EQ(foot.material(), "sole");
  // <material name="blue"> rgba 0.2 0.4 0.8 on the trunk's visual: 51, 102, 204.
  EXPECT_EQ(figure.body(0).color().r(), 51U);
  EXPECT_EQ(figure.body(0).color().g(), 102U);
  EXPECT_EQ(figure.body(0).color().b(), 204U);
}

TEST(UrdfImport, MeshesBecomeTheirHullsWithScaleAndUnits) {
  const proto::RobotFile file = load_robot_file(kData + "/test-biped.textproto");
  const proto::Figure& figure = file.description().figure();
  // The sole: a frustum 120 x 70 mm at z = -30 mm, 100 x 50 mm at -10 mm, plus the bottom's centre
  // vertex, which is not on the hull: 9 mesh vertices, 8 hull vertices. The STL is in millimetres
  // scaled by 0.001 in the URDF, the DAE in millimetres with <unit meter="0.001">.
  for (const char* name : {"l_foot", "r_foot"}) {
    const proto::Body& foot = body_named(figure, name);
    ASSERT_EQ(foot.shape_size(), 1) << name;
    ASSERT_TRUE(foot.shape(0).has_convex()) << name;
    const auto& points = foot.shape(0).convex().point_m();
    EXPECT_EQ(points.size(), 8) << name;
    Eigen::AlignedBox3d box;
    for (const proto::Vector3& p : points) box.extend(v(p));
    EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d(-0.06, -0.035, -0.03), 1e-6)) << name << " " << box.min().transpose();
    EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d(0.06, 0.035, -0.01), 1e-6)) << name << " " << box.max().transpose();
  }
  // Primitives keep their sizes and origins.
  const proto::Body& thigh = body_named(figure, "l_thigh");
  ASSERT_TRUE(thigh.shape(0).has_cylinder());
  EXPECT_DOUBLE_EQ(thigh.shape(0).cylinder().radius_m(), 0.02);
  EXPECT_DOUBLE_EQ(thigh.shape(0).cylinder().length_m(), 0.12);
  EXPECT_DOUBLE_EQ(thigh.shape(0).pose().position_m().z(), -0.06);
  EXPECT_TRUE(body_named(figure, "trunk").shape(0).has_box());
}

TEST(UrdfImport, CompiledFigureHasTheUrdfMassesInertiasAndJoints) {
  const physics::RobotModel sut =
      physics::compile_robot(load_robot_file(kData + "/test-biped.textproto"), body::motor_catalog());

  EXPECT_NEAR(sut.mass_kg, 1.2 + 2 * (0.3 + 0.3 + 0.2), 1e-12);
  ASSERT_EQ(sut.links.size(), 6U);
  ASSERT_EQ(sut.motors.size(), 6U);
  for (const physics::BodyModel& b : sut.bodies) {
    if (b.name != "l_foot" && b.name != "r_foot") continue;
    // Centre of mass 0.02 below the ankle at (0, +-0.05, -0.30); principal moments as written.
    const double y = b.name == "l_foot" ? 0.05 : -0.05;
    EXPECT_TRUE(b.X_RB.translation().isApprox(Eigen::Vector3d(0, y, -0.32), 1e-9)) << b.X_RB.translation().transpose();
    Eigen::Vector3d moments = b.inertia_kg_m2;
    std::sort(moments.data(), moments.data() + 3);
    EXPECT_TRUE(moments.isApprox(Eigen::Vector3d(0.0000883, 0.000247, 0.000322), 1e-9)) << moments.transpose();
    ASSERT_EQ(b.shapes.size(), 1U);
    EXPECT_EQ(b.shapes[0].type, physics::ShapeType::kConvex);
    EXPECT_EQ(b.shapes[0].hull->vertices.size(), 8U);
    // Prismatoid volume h / 6 (A_bottom + A_top + 4 A_middle): h = 0.02, 0.12 * 0.07, 0.10 * 0.05 and
    // 0.11 * 0.06 m^2 (the sections are not similar, so not the frustum formula).
    EXPECT_NEAR(b.shapes[0].hull->volume_m3, 0.02 / 6.0 * (0.12 * 0.07 + 0.10 * 0.05 + 4.0 * 0.11 * 0.06), 1e-10);  // float meshes
  }
  for (const physics::LinkModel& l : sut.links) {
    EXPECT_EQ(l.type, physics::JointType::kRevolute) << l.name;
    EXPECT_TRUE(l.axis_R.isApprox(Eigen::Vector3d::UnitY())) << l.name;
    EXPECT_TRUE(l.limited) << l.name;
    EXPECT_GE(l.motor, 0) << l.name;
    if (l.name == "l_knee") {
      EXPECT_TRUE(l.anchor_R.isApprox(Eigen::Vector3d(0, 0.05, -0.18))) << l.anchor_R.transpose();
      EXPECT_NEAR(l.lower, 0.0, 1e-12);
      EXPECT_NEAR(l.upper, 2.5, 1e-12);
      EXPECT_EQ(sut.motors[static_cast<size_t>(l.motor)].id, 2);
      EXPECT_EQ(sut.motors[static_cast<size_t>(l.motor)].model, "RX-64");
    }
    if (l.name == "r_ankle_pitch") {
      EXPECT_DOUBLE_EQ(sut.motors[static_cast<size_t>(l.motor)].direction, -1.0);
    }
  }
  // The IMU names imu_link, a frame 0.02 above the trunk's origin turned 90 deg about z: it moves
  // onto the trunk with that mount.
  ASSERT_EQ(sut.imus.size(), 1U);
  EXPECT_EQ(sut.bodies[static_cast<size_t>(sut.imus[0].body)].name, "trunk");
  EXPECT_TRUE(sut.imus[0].X_DS.translation().isApprox(Eigen::Vector3d(0, 0, 0.02)));
  EXPECT_TRUE(sut.imus[0].X_DS.linear().isApprox(Eigen::AngleAxisd(90 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-9));
  EXPECT_EQ(sut.feet.size(), 2U);
}

TEST(UrdfImport, AJointAxisAndInertiaAreTurnedIntoTheRobotFrame) {
  // A joint frame rolled 90 deg about x: its axis (0 0 1) is -y in the robot frame, and the child's
  // body frame is rolled with it. The bob's inertial frame rolled 90 deg about x in the link frame
  // swaps the tensor's y and z moments.
  const physics::RobotModel sut = physics::compile_robot(
      parse_robot_file("name: \"p\"\nfigure { urdf { file: \"pendulum.urdf\" joint { name: \"swing\" passive: true } } }",
                       kData + "/p.textproto"),
      body::motor_catalog());
  ASSERT_EQ(sut.links.size(), 1U);
  EXPECT_TRUE(sut.links[0].axis_R.isApprox(Eigen::Vector3d::UnitY()));
  EXPECT_TRUE(sut.links[0].anchor_R.isApprox(Eigen::Vector3d(0, 0, 0.5)));
  EXPECT_EQ(sut.links[0].motor, -1);
  const physics::BodyModel& bob = sut.bodies[1];
  EXPECT_TRUE(bob.shapes.empty());
  // Moments about the robot axes: x 0.006, y 0.005 (the inertial frame's z), z 0.002.
  const Eigen::Matrix3d I_R = bob.X_RB.linear() * bob.inertia_kg_m2.asDiagonal() * bob.X_RB.linear().transpose();
  EXPECT_TRUE(I_R.isApprox(Eigen::Vector3d(0.006, 0.005, 0.002).asDiagonal().toDenseMatrix(), 1e-9)) << I_R;
  EXPECT_TRUE(bob.X_RB.translation().isApprox(Eigen::Vector3d(0, 0, 0.3)));

  const physics::RobotModel rolled = physics::compile_robot(
      parse_robot_file("name: \"p\"\nfigure { urdf { file: \"pendulum.urdf\" pose { rpy_deg { x: 90 } } "
                       "joint { name: \"swing\" passive: true } } }",
                       kData + "/p.textproto"),
      body::motor_catalog());
  EXPECT_TRUE(rolled.links[0].axis_R.isApprox(Eigen::Vector3d::UnitZ())) << rolled.links[0].axis_R.transpose();
  EXPECT_TRUE(rolled.links[0].anchor_R.isApprox(Eigen::Vector3d(0, -0.5, 0), 1e-9)) << rolled.links[0].anchor_R.transpose();
}

// --- refusals: each names the robot file's line, the URDF file and the element ---

TEST(UrdfImportErrors, MissingFile) {
  const std::string e = error_of(biped_with("file: \"biped.urdf\"", "file: \"nope.urdf\""));
  EXPECT_NE(e.find("robot.textproto:24:"), std::string::npos) << e;
  EXPECT_NE(e.find("Urdf.file"), std::string::npos) << e;
  EXPECT_NE(e.find("nope.urdf: cannot read the URDF: no such file"), std::string::npos) << e;
}

TEST(UrdfImportErrors, NotARegularFile) {
  const std::string e = error_of(biped_with("file: \"biped.urdf\"", "file: \"meshes\""));
  EXPECT_NE(e.find("meshes: cannot read the URDF: not a regular file"), std::string::npos) << e;
}

TEST(UrdfImportErrors, MalformedXml) {
  const std::string e = error_of(single("malformed.urdf"));
  EXPECT_NE(e.find("robot.textproto:4:"), std::string::npos) << e;
  EXPECT_NE(e.find("malformed.urdf: line 5"), std::string::npos) << e;
  EXPECT_NE(e.find("malformed XML"), std::string::npos) << e;
}

TEST(UrdfImportErrors, UnknownJointInTheMap) {
  const std::string e = error_of(biped_with("joint { name: \"l_knee\"", "joint { name: \"l_elbow\""));
  EXPECT_NE(e.find("robot.textproto:28:"), std::string::npos) << e;  // the entry's line
  EXPECT_NE(e.find("biped.urdf: has no joint 'l_elbow'"), std::string::npos) << e;
  EXPECT_NE(e.find("l_knee"), std::string::npos) << e;  // listed among the movable joints
}

TEST(UrdfImportErrors, UnmappedJoint) {
  const std::string e = error_of(biped_with("    joint { name: \"r_knee\" bus: 0 id: 5 reversed: true }\n", ""));
  EXPECT_NE(e.find("robot.textproto:"), std::string::npos) << e;
  EXPECT_NE(e.find("biped.urdf: joint 'r_knee' (line "), std::string::npos) << e;
  EXPECT_NE(e.find("has no servo"), std::string::npos) << e;
}

TEST(UrdfImportErrors, ServoWithNoDevice) {
  // The generated motor reports the joint entry's line, field by name.
  const std::string e = error_of(biped_with("joint { name: \"l_knee\" bus: 0 id: 2 }", "joint { name: \"l_knee\" bus: 0 id: 42 }"));
  EXPECT_NE(e.find("robot.textproto:28:"), std::string::npos) << e;
  EXPECT_NE(e.find("no device with ID 42"), std::string::npos) << e;
}

TEST(UrdfImportErrors, FixedJointTakesNoServo) {
  const std::string e = error_of(biped_with("joint { name: \"l_knee\" bus: 0 id: 2 }",
                                            "joint { name: \"l_knee\" bus: 0 id: 2 } joint { name: \"imu_fixed\" bus: 0 id: 7 }"));
  EXPECT_NE(e.find("joint 'imu_fixed' (line "), std::string::npos) << e;
  EXPECT_NE(e.find("is fixed: it takes no servo"), std::string::npos) << e;
}

TEST(UrdfImportErrors, MissingMesh) {
  const std::string e = error_of(single("missing_mesh.urdf"));
  EXPECT_NE(e.find("missing_mesh.urdf: link 'shell' (line 3): <collision> 1 'hull': <mesh filename=\"meshes/no_such_mesh.stl\">"),
            std::string::npos)
      << e;
  EXPECT_NE(e.find("not found"), std::string::npos) << e;
}

TEST(UrdfImportErrors, MissingPackage) {
  const std::string e = error_of(single("missing_package.urdf"));
  EXPECT_NE(e.find("link 'shell'"), std::string::npos) << e;
  EXPECT_NE(e.find("package 'no_such_package' has no file 'meshes/foot.stl'"), std::string::npos) << e;
}

TEST(UrdfImportErrors, MeshThatIsNoMesh) {
  const std::string e = error_of(single("broken_mesh.urdf"));
  EXPECT_NE(e.find("broken_mesh.urdf: link 'shell'"), std::string::npos) << e;
  EXPECT_NE(e.find("cannot read mesh"), std::string::npos) << e;
}

TEST(UrdfImportErrors, MeshWithoutVolume) {
  const std::string e = error_of(single("flat_mesh.urdf"));
  EXPECT_NE(e.find("flat_mesh.urdf: link 'shell'"), std::string::npos) << e;
  EXPECT_NE(e.find("no convex hull"), std::string::npos) << e;
}

TEST(UrdfImportErrors, UnsupportedGeometry) {
  const std::string e = error_of(single("capsule.urdf"));
  EXPECT_NE(e.find("capsule.urdf: not a valid URDF"), std::string::npos) << e;
  EXPECT_NE(e.find("capsule"), std::string::npos) << e;
  EXPECT_NE(e.find("body"), std::string::npos) << e;  // the link
}

TEST(UrdfImportErrors, PassiveJointWithAServo) {
  const std::string e = error_of(biped_with("joint { name: \"l_knee\" bus: 0 id: 2 }", "joint { name: \"l_knee\" id: 2 passive: true }"));
  EXPECT_NE(e.find("robot.textproto:28:"), std::string::npos) << e;
  EXPECT_NE(e.find("a passive joint has no servo"), std::string::npos) << e;
}

TEST(UrdfImportErrors, BodiesAndUrdfTogether) {
  const std::string e = error_of(biped_with("  urdf {", "  body { name: \"x\" shape { sphere { radius_m: 0.1 } } mass_kg: 1 }\n  urdf {"));
  EXPECT_NE(e.find("not both"), std::string::npos) << e;
}

TEST(UrdfImportErrors, SensorOnAnUnknownLink) {
  const std::string e = error_of(biped_with("body: \"imu_link\"", "body: \"head\""));
  EXPECT_NE(e.find("robot.textproto:34:"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown body 'head'"), std::string::npos) << e;
}

}  // namespace
}  // namespace doppel::urdf
