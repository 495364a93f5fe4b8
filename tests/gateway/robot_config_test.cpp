#include "gateway/robot_config.h"
#include "robot_file_error.h"

#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "dynamixel/device_io.h"
#include "physics/world.h"

namespace doppel::gateway {
namespace {

const char* kGoodBus = R"(name: "r"
bus {
  baud_bps: 1000000
  protocol: PROTOCOL_1
  device { id: 1 model: "RX-64" name: "A" }
)";

TEST(RobotConfig, DefaultRobotIsTheThesisKidSizeHumanoid) {
  RobotConfig sut = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  ASSERT_EQ(sut.buses.size(), 1u);
  const BusConfig& bus = sut.buses[0];
  EXPECT_EQ(bus.baud_bps, 1000000u);
  EXPECT_EQ(bus.protocol, dynamixel::Protocol::kV1);
  std::map<std::string, int> models;
  std::map<std::string, int> ids;
  for (const DeviceConfig& device : bus.devices) {
    ++models[device.model];
    ids[device.name] = device.id;
  }
  EXPECT_EQ(models["RX-64"], 14);
  EXPECT_EQ(models["RX-28"], 7);
  EXPECT_EQ(models["FUMANOID-IMU"], 1);
  EXPECT_EQ(models["FUMANOID-FOOT"], 2);
  // Thesis figure 27b.
  EXPECT_EQ(ids["HEAD_YAW"], 2);
  EXPECT_EQ(ids["HIP_LEFT_PITCH"], 11);
  EXPECT_EQ(ids["HIP_RIGHT_PITCH"], 12);
  EXPECT_EQ(ids["KNEE_LEFT_PITCH"], 15);
  EXPECT_EQ(ids["KNEE_RIGHT_PITCH"], 16);
  EXPECT_EQ(ids["FOOT_LEFT_PITCH"], 19);
  EXPECT_EQ(ids["FOOT_RIGHT_PITCH"], 20);
}

// darwinop-ens/darwin-op Framework/include/JointData.h (IDs 1..20), CM730.h (ID_CM 200), FSR.h
// (ID_R_FSR 111, ID_L_FSR 112).
TEST(RobotConfig, DarwinOpHasTheFrameworksIdsOnOneBus) {
  RobotConfig sut = load_robot("darwin-op", DOPPEL_ROBOTS_DIR);
  ASSERT_EQ(sut.buses.size(), 1u);
  const BusConfig& bus = sut.buses[0];
  EXPECT_EQ(bus.baud_bps, 1000000u);
  EXPECT_EQ(bus.protocol, dynamixel::Protocol::kV1);
  const char* joints[] = {"R_SHOULDER_PITCH", "L_SHOULDER_PITCH", "R_SHOULDER_ROLL", "L_SHOULDER_ROLL",
                          "R_ELBOW",          "L_ELBOW",          "R_HIP_YAW",       "L_HIP_YAW",
                          "R_HIP_ROLL",       "L_HIP_ROLL",       "R_HIP_PITCH",     "L_HIP_PITCH",
                          "R_KNEE",           "L_KNEE",           "R_ANKLE_PITCH",   "L_ANKLE_PITCH",
                          "R_ANKLE_ROLL",     "L_ANKLE_ROLL",     "HEAD_PAN",        "HEAD_TILT"};
  std::map<std::string, std::pair<int, std::string>> devices;
  for (const DeviceConfig& device : bus.devices) devices[device.name] = {device.id, device.model};
  ASSERT_EQ(devices.size(), 23u);
  for (int id = 1; id <= 20; ++id) {
    EXPECT_EQ(devices[joints[id - 1]], std::make_pair(id, std::string("MX-28"))) << joints[id - 1];
  }
  EXPECT_EQ(devices["CM730"], std::make_pair(200, std::string("CM-730")));
  EXPECT_EQ(devices["R_FSR"], std::make_pair(111, std::string("DARWIN-FSR")));
  EXPECT_EQ(devices["L_FSR"], std::make_pair(112, std::string("DARWIN-FSR")));
}

TEST(RobotConfig, EveryShippedRobotLoads) {
  std::vector<std::string> names = list_robots(DOPPEL_ROBOTS_DIR);
  EXPECT_GE(names.size(), 2u);
  for (const std::string& name : names) {
    EXPECT_NO_THROW(load_robot(name, DOPPEL_ROBOTS_DIR)) << name;
  }
}

TEST(RobotConfig, NamesAndFilesResolve) {
  EXPECT_EQ(resolve_robot_path("mx-test", "/r"), "/r/mx-test.textproto");
  EXPECT_EQ(resolve_robot_path("./my.textproto", "/r"), "./my.textproto");
  EXPECT_EQ(resolve_robot_path("x/y", "/r"), "x/y");
}

TEST(RobotConfig, UnknownRobotNameListsTheShippedOnes) {
  try {
    load_robot("no-such-robot", DOPPEL_ROBOTS_DIR);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fumanoid-2011"), std::string::npos) << e.what();
  }
  EXPECT_THROW(load_robot("/nonexistent/robot.textproto", DOPPEL_ROBOTS_DIR), std::runtime_error);
}

TEST(RobotConfig, SyntaxErrorNamesFileAndLine) {
  std::string error = error_of("name: \"r\"\nbus {\n  baud_bps: fast\n}\n");
  EXPECT_EQ(error.rfind("robots/bad.textproto:3:", 0), 0u) << error;
}

TEST(RobotConfig, UnknownFieldNamesFileAndLine) {
  std::string error = error_of("name: \"r\"\nbus {\n  speed: 3\n}\n");
  EXPECT_EQ(error.rfind("robots/bad.textproto:3:", 0), 0u) << error;
  EXPECT_NE(error.find("speed"), std::string::npos) << error;
}

TEST(RobotConfig, UnknownModelNamesLineFieldAndKnownModels) {
  std::string error = error_of(std::string(kGoodBus) + "  device { id: 2 model: \"RX-99\" }\n}\n");
  EXPECT_EQ(error.rfind("robots/bad.textproto:6:", 0), 0u) << error;
  EXPECT_NE(error.find("Device.model"), std::string::npos) << error;
  EXPECT_NE(error.find("RX-99"), std::string::npos) << error;
  EXPECT_NE(error.find("MX-106"), std::string::npos) << error;
}

TEST(RobotConfig, DuplicateIdIsRejected) {
  std::string error = error_of(std::string(kGoodBus) + "  device { id: 1 model: \"RX-28\" }\n}\n");
  EXPECT_EQ(error.rfind("robots/bad.textproto:6:", 0), 0u) << error;
  EXPECT_NE(error.find("used twice"), std::string::npos) << error;
}

// Issue 16: a device without `id` silently became ID 0.
TEST(RobotConfig, MissingIdIsAnErrorNamingTheDevicesLine) {
  std::string error = error_of(std::string(kGoodBus) + "  device { model: \"RX-28\" name: \"B\" }\n}\n");
  EXPECT_EQ(error.rfind("robots/bad.textproto:6:3: Device.id: missing ID", 0), 0u) << error;
  EXPECT_NO_THROW(parse_robot("name: \"r\"\nbus {\n baud_bps: 1000000\n protocol: PROTOCOL_1\n"
                              " device { id: 0 model: \"RX-28\" }\n}\n",
                              "x"))
      << "an explicit ID 0 is still allowed";
}

TEST(RobotConfig, IdOutOfRangeIsRejected) {
  std::string error = error_of(std::string(kGoodBus) + "  device { id: 254 model: \"RX-28\" }\n}\n");
  EXPECT_NE(error.find("Device.id"), std::string::npos) << error;
}

TEST(RobotConfig, BaudRateTheRegisterCannotHoldIsRejected) {
  // 2 Mbps is an MX-only rate (reference 3.2); 1.5 Mbps is not 2 000 000 / (n + 1) within 3 %.
  std::string rx = error_of("name: \"r\"\nbus {\n baud_bps: 2000000\n protocol: PROTOCOL_1\n"
                            " device { id: 1 model: \"RX-28\" }\n}\n");
  EXPECT_NE(rx.find("Bus.baud_bps"), std::string::npos) << rx;
  std::string odd = error_of("name: \"r\"\nbus {\n baud_bps: 1500000\n protocol: PROTOCOL_1\n"
                             " device { id: 1 model: \"MX-28\" }\n}\n");
  EXPECT_NE(odd.find("Bus.baud_bps"), std::string::npos) << odd;
  EXPECT_NO_THROW(parse_robot("name: \"r\"\nbus {\n baud_bps: 57600\n protocol: PROTOCOL_1\n"
                              " device { id: 1 model: \"RX-28\" }\n}\n", "x"));
}

TEST(RobotConfig, AdapterAndLatencyTimerPerBus) {
  const std::string bus_head = "name: \"r\"\nbus {\n baud_bps: 1000000\n protocol: PROTOCOL_1\n";
  const std::string servo = " device { id: 1 model: \"AX-12A\" }\n}\n";
  RobotConfig ftdi = parse_robot(bus_head + servo, "x");
  EXPECT_EQ(ftdi.buses[0].adapter, bus::AdapterProfile::kFtdi);
  EXPECT_FALSE(ftdi.buses[0].latency_timer_ms.has_value());
  RobotConfig usb2ax = parse_robot(bus_head + " adapter: \"usb2ax\"\n" + servo, "x");
  EXPECT_EQ(usb2ax.buses[0].adapter, bus::AdapterProfile::kUsb2ax);
  RobotConfig timer = parse_robot(bus_head + " adapter: \"ftdi\" latency_timer_ms: 1\n" + servo, "x");
  EXPECT_EQ(timer.buses[0].latency_timer_ms, 1u);

  const std::string unknown = error_of(bus_head + " adapter: \"cp2102\"\n" + servo);
  EXPECT_NE(unknown.find("Bus.adapter"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("usb2ax"), std::string::npos) << unknown;
  const std::string no_timer = error_of(bus_head + " adapter: \"usb2ax\" latency_timer_ms: 16\n" + servo);
  EXPECT_NE(no_timer.find("Bus.latency_timer_ms"), std::string::npos) << no_timer;
  const std::string range = error_of(bus_head + " latency_timer_ms: 256\n" + servo);
  EXPECT_NE(range.find("1..255"), std::string::npos) << range;
  const std::string own_id =
      error_of(bus_head + " adapter: \"usb2ax\"\n device { id: 253 model: \"AX-12A\" }\n}\n");
  EXPECT_NE(own_id.find("Device.id"), std::string::npos) << own_id;
}

TEST(RobotConfig, BusWithoutSupplyRunsOnTheFumanoidBattery) {
  // The FUmanoid's battery is a 4S LiPo: 4 cells x 3.7 V nominal. A bus that names its own supply keeps it.
  RobotConfig sut = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  RobotConfig twelve_volts = parse_robot("name: \"r\"\nbus {\n baud_bps: 57600\n protocol: PROTOCOL_1\n"
                                         " supply_voltage_v: 12\n device { id: 1 model: \"RX-28\" }\n}\n", "x");

  EXPECT_DOUBLE_EQ(sut.buses[0].supply_voltage_v, 4 * 3.7);
  EXPECT_DOUBLE_EQ(physics::WorldOptions{}.supply_voltage_v, 4 * 3.7);
  EXPECT_DOUBLE_EQ(dynamixel::ServoFeedback{}.voltage_v, 4 * 3.7);
  EXPECT_DOUBLE_EQ(twelve_volts.buses[0].supply_voltage_v, 12.0);
}

TEST(RobotConfig, MissingPiecesAreNamed) {
  EXPECT_NE(error_of("bus { baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: \"RX-28\" } }")
                .find("RobotDescription.name"),
            std::string::npos);
  EXPECT_NE(error_of("name: \"r\"").find("RobotDescription.bus"), std::string::npos);
  EXPECT_NE(error_of("name: \"r\" bus { baud_bps: 1000000 device { id: 1 model: \"RX-28\" } }").find("Bus.protocol"),
            std::string::npos);
  EXPECT_NE(error_of("name: \"r\" bus { protocol: PROTOCOL_1 device { id: 1 model: \"RX-28\" } }").find("Bus.baud_bps"),
            std::string::npos);
  EXPECT_NE(error_of("name: \"r\" bus { baud_bps: 1000000 protocol: PROTOCOL_1 }").find("Bus.device"),
            std::string::npos);
}

}  // namespace
}  // namespace doppel::gateway

namespace doppel::gateway {
namespace {

std::string default_robot_with_camera(const std::string& camera) {
  std::ifstream in(std::string(DOPPEL_ROBOTS_DIR) + "/fumanoid-2011.textproto");
  std::stringstream text;
  text << in.rdbuf();
  std::string robot = text.str();
  const std::string head_camera = R"(camera { name: "HEAD_CAMERA" body: "head" mount { position_m { x: 0.03 } } })";
  std::size_t at = robot.find(head_camera);
  EXPECT_NE(at, std::string::npos) << "the default robot's camera line changed";
  return robot.replace(at, head_camera.size(), camera);
}

TEST(RobotCameras, DefaultRobotHasTheWideHeadCamera) {
  RobotConfig sut = load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR);
  ASSERT_EQ(sut.cameras.size(), 1u);
  const camera::CameraConfig& head = sut.cameras[0].config;
  EXPECT_EQ(head.name, "HEAD_CAMERA");
  EXPECT_EQ(head.mount.body, "head");
  EXPECT_EQ(sut.body->bodies[sut.cameras[0].body].name, "head");
  EXPECT_EQ(head.width_px, 640);
  EXPECT_EQ(head.height_px, 480);
  EXPECT_DOUBLE_EQ(head.fps, 20.0);  // thesis 4.2.1.1
  EXPECT_EQ(head.format, camera::PixelFormat::kYuyv);
  EXPECT_EQ(head.lens.model, camera::LensModel::kEquidistant);
}

TEST(RobotCameras, SensorAndLensComeFromTheFile) {
  RobotConfig sut = parse_robot(default_robot_with_camera(
                                    R"(camera { name: "EYE" body: "head" width_px: 320 height_px: 240 fps: 30
                                                format: "bayer_rggb" lens: "pinhole" hfov_deg: 90 })"),
                                "robots/custom.textproto");
  ASSERT_EQ(sut.cameras.size(), 1u);
  const camera::CameraConfig& eye = sut.cameras[0].config;
  EXPECT_EQ(eye.name, "EYE");
  EXPECT_EQ(eye.width_px, 320);
  EXPECT_EQ(eye.height_px, 240);
  EXPECT_DOUBLE_EQ(eye.fps, 30.0);
  EXPECT_EQ(eye.format, camera::PixelFormat::kBayerRggb);
  EXPECT_EQ(eye.lens.model, camera::LensModel::kPinhole);
  // 90 degrees across 320 pixels: focal length 160 px.
  EXPECT_NEAR(eye.lens.fx_px, 160.0, 1e-6);
}

TEST(RobotCameras, BadSettingsNameFileLineAndField) {
  auto error_of = [](const std::string& camera) {
    try {
      parse_robot(default_robot_with_camera(camera), "robots/custom.textproto");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  std::string format = error_of(R"(camera { name: "EYE" body: "head" format: "bayer_xyz" })");
  EXPECT_EQ(format.rfind("robots/custom.textproto:", 0), 0u) << format;
  EXPECT_NE(format.find("CameraMount.format"), std::string::npos) << format;
  EXPECT_NE(format.find("bayer_rggb"), std::string::npos) << format;  // lists the known formats
  std::string lens = error_of(R"(camera { name: "EYE" body: "head" lens: "anamorphic" })");
  EXPECT_NE(lens.find("CameraMount.lens"), std::string::npos) << lens;
  std::string odd = error_of(R"(camera { name: "EYE" body: "head" width_px: 641 height_px: 480 })");
  EXPECT_NE(odd.find("even width"), std::string::npos) << odd;  // YUV422 pairs pixels
  std::string fov = error_of(R"(camera { name: "EYE" body: "head" lens: "equidistant" hfov_deg: 190 })");
  EXPECT_NE(fov.find("robots/custom.textproto:"), std::string::npos) << fov;
}

}  // namespace
}  // namespace doppel::gateway

namespace doppel::gateway {
namespace {

// A robot file may ask for more constraint-solver sweeps; the OP3's does (its light links).
TEST(RobotConfig, AFigureMayAskForSolverSweepsWithinRange) {
  EXPECT_EQ(load_robot("op3", DOPPEL_ROBOTS_DIR).solver_iterations, 100);
  EXPECT_FALSE(load_robot("fumanoid-2011", DOPPEL_ROBOTS_DIR).solver_iterations.has_value());
  const std::string figure =
      "name: \"r\"\nbus { baud_bps: 1000000 protocol: PROTOCOL_1 device { id: 1 model: \"RX-28\" } }\nfigure {\n  solver_iterations: 0\n"
      "  body { name: \"b\" shape { box { size_m { x: 0.1 y: 0.1 z: 0.1 } } } mass_kg: 1 }\n}\n";
  const std::string error = error_of(figure);
  EXPECT_NE(error.find("robots/bad.textproto:4:"), std::string::npos) << error;
  EXPECT_NE(error.find("solver_iterations: must be within 1..1000, got 0"), std::string::npos) << error;
}

}  // namespace
}  // namespace doppel::gateway
