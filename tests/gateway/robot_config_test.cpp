#include "gateway/robot_config.h"

#include <gtest/gtest.h>

#include <map>
#include <stdexcept>
#include <string>

namespace doppel::gateway {
namespace {

std::string error_of(const std::string& text) {
  try {
    parse_robot(text, "robots/bad.textproto");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

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
