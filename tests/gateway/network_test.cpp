// Hardware in the loop over a network: Doppel's link served on loopback by scripts/serve-network
// (ser2net), reached from the "robot's" side through a pty that socat bridges to it. Expected
// packets come from shared/reference/dynamixel.md, as in bus_integration_test.cpp.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <tuple>

#include "doppel_process.h"
#include "network_bridge.h"
#include "reference_client.h"

namespace doppel::testing {
namespace {

constexpr uint32_t kBaud = 1000000;
constexpr uint8_t kPing = 0x01, kRead = 0x02;
// A status crosses socat and ser2net, two more processes to schedule: on a loaded machine that can
// take longer than the 200 ms a local client waits. These tests check the bytes, not the time.
constexpr int kTimeoutMs = 2000;

#define SKIP_WITHOUT_NETWORK_TOOLS()                                                                      \
  do {                                                                                                    \
    if (!find_program("ser2net") || !find_program("socat")) {                                             \
      GTEST_SKIP() << "ser2net or socat is not installed (Debian packages ser2net, socat; scripts/setup " \
                      "installs them)";                                                                   \
    }                                                                                                     \
  } while (0)

// The first transaction may go out before socat has connected and ser2net has opened the pty:
// retried for up to 5 s, as a driver retries a servo that does not answer yet.
Bytes first_transaction(SerialClient& client, const Bytes& request, std::size_t expected) {
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  Bytes reply;
  while (reply.size() != expected && std::chrono::steady_clock::now() < deadline) {
    reply = client.transact(request, expected, kTimeoutMs);
  }
  return reply;
}

std::string robot_pty(const DoppelProcess& doppel) {
  return std::filesystem::path(doppel.link_dir()).parent_path().string() + "/robot-ttyUSB0";
}

TEST(Network, PingAndReadThroughSer2netAndSocatGetTheReferenceStatus) {
  SKIP_WITHOUT_NETWORK_TOOLS();
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "wire"});
  NetworkBridge bridge(doppel.link_dir(), free_loopback_ports(1), kBaud, 0, robot_pty(doppel));
  SerialClient robot(bridge.path(), kBaud);
  // Reference §1.7: PING ID 1 = FF FF 01 02 01 FB, its status FF FF 01 02 00 FC.
  EXPECT_EQ(first_transaction(robot, {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB}, 6),
            (Bytes{0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC}))
      << bridge.output();
  // Model Number of the MX-64 (ID 2): 310 (reference §3.1).
  EXPECT_EQ(robot.transact(p1_instruction(2, kRead, {0, 2}), 8, kTimeoutMs), p1_instruction(2, 0, {310 & 0xFF, 310 >> 8}));
  for (int i = 0; i < 50; ++i) {
    ASSERT_EQ(robot.transact(p1_instruction(1, kPing), 6, kTimeoutMs), p1_instruction(1, 0)) << "transaction " << i;
  }
}

TEST(Network, Ser2netOpensTheLinkAtTheRateItIsGiven) {
  SKIP_WITHOUT_NETWORK_TOOLS();
  // The bus runs at 1 Mbps; served at 57600 bps every packet reaches Doppel at the wrong rate,
  // and a real servo would not understand it either, whatever rate the robot's pty is set to.
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "wire"});
  NetworkBridge bridge(doppel.link_dir(), free_loopback_ports(1), 57600, 0, robot_pty(doppel));
  SerialClient robot(bridge.path(), kBaud);
  EXPECT_TRUE(first_transaction(robot, p1_instruction(1, kPing), 6).empty());
  EXPECT_NE(doppel.stop(), -1);
  const std::string output = doppel.output();
  const std::string counter = "not understood at the line's baud rate ";
  const std::size_t at = output.find(counter);
  ASSERT_NE(at, std::string::npos) << output;
  EXPECT_GT(std::stoi(output.substr(at + counter.size())), 0) << output;
}

TEST(Network, TheRobotMayCloseAndReopenItsPty) {
  SKIP_WITHOUT_NETWORK_TOOLS();
  // DynamixelSDK's setBaudRate closes and reopens the port; socat keeps the TCP session meanwhile.
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "fast"});
  NetworkBridge bridge(doppel.link_dir(), free_loopback_ports(1), kBaud, 0, robot_pty(doppel));
  {
    SerialClient first(bridge.path(), kBaud);
    ASSERT_EQ(first_transaction(first, p1_instruction(1, kPing), 6), p1_instruction(1, 0)) << bridge.output();
  }
  for (int open = 0; open < 5; ++open) {
    SerialClient again(bridge.path(), kBaud);
    EXPECT_EQ(again.transact(p1_instruction(3, kPing), 6, kTimeoutMs), p1_instruction(3, 0)) << "reopen " << open;
  }
}

TEST(Network, AnRfc2217ClientSetsTheRateDoppelSees) {
  SKIP_WITHOUT_NETWORK_TOOLS();
  if (run_command("/usr/bin/python3 -c 'import serial.rfc2217'").first != 0) {
    GTEST_SKIP() << "/usr/bin/python3 has no pyserial (Debian package python3-serial; scripts/setup installs it)";
  }
  // Served at 57600 bps; pyserial asks for 1 Mbps over RFC 2217 and ser2net sets it on the pty.
  // ?ign_set_control: ser2net 4 does not confirm pyserial's flow-control request (pyserial's
  // documented option for such servers).
  DoppelProcess doppel({"--robot", "mx-test", "--timing", "wire"});
  const int port = free_loopback_ports(1);
  ChildProcess server({serve_network_script(), "--link-dir", doppel.link_dir(), "--port", std::to_string(port),
                       "--baud", "57600", "--rfc2217"});
  const std::string url = "'rfc2217://127.0.0.1:" + std::to_string(port) + "?ign_set_control'";
  const std::string script = std::filesystem::path(serve_network_script()).parent_path().parent_path().string() +
                             "/tests/gateway/scripts/rfc2217_ping.py";
  auto [code, output] = run_command("/usr/bin/python3 " + script + " " + url + " 1000000 3 20");
  for (int attempt = 0; attempt < 50 && output.find("Connection refused") != std::string::npos; ++attempt) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));  // ser2net still starting
    std::tie(code, output) = run_command("/usr/bin/python3 " + script + " " + url + " 1000000 3 20");
  }
  EXPECT_EQ(code, 0) << output << server.output();
  EXPECT_NE(output.find("ok 20/20"), std::string::npos) << output;
}

TEST(Network, ServeNetworkNamesWhatIsWrong) {
  auto [missing_code, missing] = run_command(serve_network_script() + " --link-dir /nonexistent/doppel-links");
  EXPECT_EQ(missing_code, 1);
  EXPECT_NE(missing.find("'/nonexistent/doppel-links' does not exist"), std::string::npos) << missing;

  char dir_template[] = "/tmp/doppel-serve-XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  auto [empty_code, empty] = run_command(serve_network_script() + " --link-dir " + dir);
  EXPECT_EQ(empty_code, 1);
  EXPECT_NE(empty.find("no ttyDXL links in '" + dir + "'"), std::string::npos) << empty;

  std::filesystem::create_symlink("/dev/null", dir + "/ttyDXL0");
  auto [port_code, port] = run_command(serve_network_script() + " --link-dir " + dir + " --port 70000");
  EXPECT_EQ(port_code, 2);
  EXPECT_NE(port.find("'70000' is not a TCP port"), std::string::npos) << port;
  auto [baud_code, baud] = run_command(serve_network_script() + " --link-dir " + dir + " --baud ttyDXL7=57600");
  EXPECT_EQ(baud_code, 2);
  EXPECT_NE(baud.find("'ttyDXL7', which is not a link"), std::string::npos) << baud;

  // ser2net itself would only log a port it cannot bind and run on without it.
  int listener = ::socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(listener, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof(address);
  ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
  ASSERT_EQ(::listen(listener, 1), 0);
  ASSERT_EQ(::getsockname(listener, reinterpret_cast<sockaddr*>(&address), &length), 0);
  const std::string taken = std::to_string(ntohs(address.sin_port));
  auto [busy_code, busy] = run_command(serve_network_script() + " --link-dir " + dir + " --port " + taken);
  ::close(listener);
  EXPECT_EQ(busy_code, 1);
  EXPECT_NE(busy.find("port " + taken + " on 127.0.0.1 is in use"), std::string::npos) << busy;
  std::filesystem::remove_all(dir);
}

TEST(Network, ServeNetworkListensOnLoopbackUnlessTold) {
  char dir_template[] = "/tmp/doppel-serve-XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  std::filesystem::create_directory(dir + "/robot1");
  std::filesystem::create_symlink("/dev/null", dir + "/ttyDXL0");
  std::filesystem::create_symlink("/dev/null", dir + "/robot1/ttyDXL0");
  auto [code, config] = run_command(serve_network_script() + " --link-dir " + dir +
                                    " --port 5000 --baud robot1/ttyDXL0=4000000 --print-config");
  EXPECT_EQ(code, 0) << config;
  EXPECT_NE(config.find("accepter: tcp,127.0.0.1,5000\n  connector: serialdev," + dir + "/ttyDXL0,1000000n81,local"),
            std::string::npos)
      << config;
  EXPECT_NE(config.find("accepter: tcp,127.0.0.1,5001\n  connector: serialdev," + dir +
                        "/robot1/ttyDXL0,4000000n81,local"),
            std::string::npos)
      << config;
  auto [rfc_code, rfc] = run_command(serve_network_script() + " --link-dir " + dir + " --rfc2217 --print-config");
  EXPECT_EQ(rfc_code, 0);
  EXPECT_NE(rfc.find("accepter: telnet(rfc2217),tcp,127.0.0.1,4000"), std::string::npos) << rfc;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace doppel::testing
