// Robot files: initial register values per device (by name or address, checked against the model's
// control table) and per-device protocols on one bus (docs/devices.md "Robot files").
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "gateway/robot_config.h"
#include "robot_file_error.h"

namespace doppel::gateway {
namespace {

std::string p1_device(const std::string& model, const std::string& initial) {
  return "name: \"r\"\nbus {\n  baud_bps: 1000000\n  protocol: PROTOCOL_1\n  device {\n    id: 1 model: \"" + model +
         "\" name: \"A\"\n" + initial + "  }\n}\n";
}

TEST(InitialRegisters, ByNameAndByAddressInFileOrder) {
  const RobotConfig sut = parse_robot(p1_device("MX-28", "    initial { item: \"Return Delay Time\" value: 0 }\n"
                                                         "    initial { address: 28 value: 64 }\n"),
                                      "r.textproto");
  const std::vector<InitialValue>& initial = sut.buses[0].devices[0].initial;
  ASSERT_EQ(initial.size(), 2u);
  // MX-28 control table (reference §3.5): Return Delay Time at 5 (EEPROM), P Gain at 28 (RAM).
  EXPECT_EQ(initial[0].address, 5);
  EXPECT_EQ(initial[0].value, 0);
  EXPECT_TRUE(initial[0].eeprom);
  EXPECT_EQ(initial[1].item, "P Gain");
  EXPECT_EQ(initial[1].value, 64);
  EXPECT_FALSE(initial[1].eeprom);
  EXPECT_NE(initial[1].location.find("r.textproto:8:"), std::string::npos) << initial[1].location;
}

TEST(InitialRegisters, BadEntriesNameFileLineAndItem) {
  // A read-only item (Model Number, reference §3.4).
  std::string e = error_of(p1_device("RX-64", "    initial { item: \"Model Number\" value: 64 }\n"));
  EXPECT_NE(e.find("robots/bad.textproto:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("Model Number (0) is read-only"), std::string::npos) << e;
  // An unknown name.
  e = error_of(p1_device("RX-64", "    initial { item: \"Goal Velocity\" value: 1 }\n"));
  EXPECT_NE(e.find("robots/bad.textproto:7:"), std::string::npos) << e;
  EXPECT_NE(e.find("'Goal Velocity' is no item of RX-64"), std::string::npos) << e;
  // Out of range: Status Return Level is 0..2.
  e = error_of(p1_device("RX-64", "    initial { item: \"Status Return Level\" value: 3 }\n"));
  EXPECT_NE(e.find("Status Return Level (16) = 3 is outside 0..2"), std::string::npos) << e;
  // An address inside an item (Goal Position is 30..31).
  e = error_of(p1_device("RX-64", "    initial { address: 31 value: 1 }\n"));
  EXPECT_NE(e.find("no item of RX-64 starts at address 31"), std::string::npos) << e;
  // Neither name nor address, or both.
  e = error_of(p1_device("RX-64", "    initial { value: 1 }\n"));
  EXPECT_NE(e.find("by name"), std::string::npos) << e;
  // The id field is the ID: an initial ID that differs is a conflict; the bus sets Baud Rate.
  e = error_of(p1_device("RX-64", "    initial { item: \"ID\" value: 7 }\n"));
  EXPECT_NE(e.find("conflicts with the device's id 1"), std::string::npos) << e;
  e = error_of(p1_device("RX-64", "    initial { item: \"Baud Rate\" value: 1 }\n"));
  EXPECT_NE(e.find("set by the bus' baud_bps"), std::string::npos) << e;
  e = error_of(p1_device("RX-64", "    return_delay_time_raw: 0\n    initial { item: \"Return Delay Time\" value: 0 }\n"));
  EXPECT_NE(e.find("also set by return_delay_time_raw"), std::string::npos) << e;
  e = error_of(p1_device("RX-64", "    initial { item: \"LED\" value: 1 }\n    initial { address: 25 value: 0 }\n"));
  EXPECT_NE(e.find("LED (25) is set twice"), std::string::npos) << e;
}

TEST(InitialRegisters, Protocol2ItemsAreCheckedAgainstTheXTable) {
  const std::string head = "name: \"r\"\nbus {\n  baud_bps: 1000000\n  protocol: PROTOCOL_2\n  device {\n"
                           "    id: 1 model: \"XM430-W350\" name: \"A\"\n";
  // XM430-W350 (reference §3.7): Protocol Type 13 takes 1 or 2; Homing Offset 20 is signed.
  const RobotConfig sut = parse_robot(head + "    initial { item: \"Protocol Type\" value: 1 }\n"
                                             "    initial { item: \"Homing Offset\" value: -1024 }\n  }\n}\n",
                                      "r.textproto");
  EXPECT_EQ(sut.buses[0].devices[0].initial.at(0).address, 13);
  EXPECT_EQ(sut.buses[0].devices[0].initial.at(1).value, -1024);
  const std::string e = error_of(head + "    initial { item: \"Protocol Type\" value: 3 }\n  }\n}\n");
  EXPECT_NE(e.find("Protocol Type (13) = 3 is outside"), std::string::npos) << e;
}

// DynamixelSDK's protocol_combined example: an MX-28 with Protocol 1.0 firmware beside Protocol 2.0 servos.
TEST(DeviceProtocol, AProtocol1ModelSitsOnAProtocol2BusWhenTheDeviceSaysSo) {
  const RobotConfig sut = parse_robot(R"(name: "combined"
bus {
  baud_bps: 57600
  protocol: PROTOCOL_2
  device { id: 1 model: "MX-28" name: "P1" protocol: PROTOCOL_1 }
  device { id: 2 model: "XM430-W350" name: "P2" }
  device { id: 3 model: "XM430-W350" name: "P2_AS_P1" protocol: PROTOCOL_1 }
}
)",
                                      "combined.textproto");
  const BusConfig& bus = sut.buses[0];
  EXPECT_EQ(bus.protocol, dynamixel::Protocol::kV2);
  EXPECT_EQ(bus.devices[0].firmware, dynamixel::Protocol::kV1);
  EXPECT_EQ(bus.devices[1].firmware, dynamixel::Protocol::kV2);
  // An X servo told to speak Protocol 1.0 starts with Protocol Type 1 (reference §3.7, address 13).
  EXPECT_EQ(bus.devices[2].firmware, dynamixel::Protocol::kV2);
  ASSERT_EQ(bus.devices[2].initial.size(), 1u);
  EXPECT_EQ(bus.devices[2].initial[0].address, 13);
  EXPECT_EQ(bus.devices[2].initial[0].value, 1);
}

TEST(DeviceProtocol, MismatchesAreNamed) {
  // A Protocol 1.0 model on a Protocol 2.0 bus without the device's protocol.
  std::string e = error_of("name: \"r\"\nbus {\n  baud_bps: 57600\n  protocol: PROTOCOL_2\n"
                           "  device { id: 1 model: \"MX-28\" }\n}\n");
  EXPECT_NE(e.find("robots/bad.textproto:5:"), std::string::npos) << e;
  EXPECT_NE(e.find("MX-28 is a Protocol 1.0 model; this bus is PROTOCOL_2"), std::string::npos) << e;
  // A Protocol 1.0 firmware cannot be told to speak Protocol 2.0.
  e = error_of("name: \"r\"\nbus {\n  baud_bps: 57600\n  protocol: PROTOCOL_1\n"
               "  device { id: 1 model: \"MX-28\" protocol: PROTOCOL_2 }\n}\n");
  EXPECT_NE(e.find("MX-28 is a Protocol 1.0 model"), std::string::npos) << e;
  // Boards of the Protocol 2.0 registry have no Protocol 1.0 mode.
  e = error_of("name: \"r\"\nbus {\n  baud_bps: 1000000\n  protocol: PROTOCOL_2\n"
               "  device { id: 241 model: \"BITBOTS-IMU\" protocol: PROTOCOL_1 }\n}\n");
  EXPECT_NE(e.find("BITBOTS-IMU cannot speak Protocol 1.0"), std::string::npos) << e;
}

}  // namespace
}  // namespace doppel::gateway
