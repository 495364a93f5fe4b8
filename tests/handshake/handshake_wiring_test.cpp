// doppel's handshake options and their wiring (gateway/handshake_service.h): defaults, what each
// option changes, and what happens when a port is taken.
#include "gateway/handshake_service.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <sstream>
#include <vector>

#include "fake_robot_host.h"
#include "test_client.h"

namespace doppel::gateway {
namespace {

using handshake::testing::FakeRobotHost;
using handshake::testing::TestClient;

Options parse(std::vector<const char*> args) {
  args.insert(args.begin(), "doppel");
  return parse_options(static_cast<int>(args.size()), args.data());
}

TEST(HandshakeOptions, DefaultsServeTheLinkDirectorysSocketAndLoopbackPort7590) {
  const Options o = parse({"--link-dir", "/run/x"});
  EXPECT_TRUE(o.handshake.enabled);
  const handshake::ServerOptions s = handshake_options(o, "");
  EXPECT_EQ(s.unix_path, "/run/x/handshake.sock");
  EXPECT_EQ(s.tcp_port, uint16_t{7590});
  EXPECT_EQ(s.tcp_address, "127.0.0.1");
}

TEST(HandshakeOptions, EachOptionChangesItsPart) {
  const handshake::ServerOptions s = handshake_options(
      parse({"--handshake-socket", "/tmp/h.sock", "--handshake-port", "0", "--handshake-address", "::1"}), "secret");
  EXPECT_EQ(s.unix_path, "/tmp/h.sock");
  EXPECT_EQ(s.tcp_port, uint16_t{0});
  EXPECT_EQ(s.tcp_address, "::1");
  EXPECT_EQ(s.tcp_token, "secret");
  EXPECT_FALSE(handshake_options(parse({"--no-handshake-tcp"}), "").tcp_port.has_value());
  EXPECT_FALSE(parse({"--no-handshake"}).handshake.enabled);
  EXPECT_THROW(parse({"--handshake-port", "65536"}), std::invalid_argument);
  EXPECT_THROW(parse({"--handshake-socket", ""}), std::invalid_argument);
  for (const char* option : {"--handshake-socket PATH", "--handshake-port PORT", "--handshake-address ADDR",
                             "--no-handshake-tcp", "--no-handshake "}) {
    EXPECT_NE(usage().find(option), std::string::npos) << option;
  }
}

class LinkDir : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/doppel-handshake-wiring-XXXXXX";
    dir_ = mkdtemp(pattern);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string dir_;
  FakeRobotHost host_;
};

TEST_F(LinkDir, ServesTheHostOnBothEndpoints) {
  std::ostringstream notes;
  auto server = start_handshake(parse({"--link-dir", dir_.c_str(), "--handshake-port", "0"}), host_, "", notes);
  ASSERT_TRUE(server);
  EXPECT_EQ(server->unix_path(), dir_ + "/handshake.sock");
  ASSERT_NE(server->tcp_port(), 0);
  proto::handshake::ClientMessage list;
  list.mutable_list_robots();
  EXPECT_EQ(TestClient::unix_socket(server->unix_path()).call(list).robot_list().robot(0).name(), "fumanoid-2011");
  EXPECT_EQ(TestClient::tcp(server->tcp_port()).call(list).robot_list().robot_size(), 1);
  EXPECT_TRUE(notes.str().empty());
  EXPECT_FALSE(start_handshake(parse({"--no-handshake"}), host_, "", notes));
}

// Holds a loopback TCP port (7590 if it is free: then the default is taken for sure).
struct PortHolder {
  PortHolder() {
    fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(7590);
    if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      a.sin_port = 0;
      bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    }
    listen(fd, 1);
    socklen_t n = sizeof a;
    getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
    port = ntohs(a.sin_port);
  }
  ~PortHolder() { close(fd); }
  int fd;
  uint16_t port;
};

TEST_F(LinkDir, ATakenDefaultPortLeavesTheUnixSocketAndSaysSo) {
  PortHolder holder;  // 7590, or held by someone else already: taken either way
  std::ostringstream notes;
  auto server = start_handshake(parse({"--link-dir", dir_.c_str()}), host_, "", notes);
  ASSERT_TRUE(server);
  EXPECT_EQ(server->tcp_port(), 0);
  EXPECT_NE(notes.str().find("handshake over TCP off"), std::string::npos) << notes.str();
  proto::handshake::ClientMessage list;
  list.mutable_list_robots();
  EXPECT_TRUE(TestClient::unix_socket(server->unix_path()).call(list).has_robot_list());
}

TEST_F(LinkDir, ATakenNamedPortIsAnError) {
  PortHolder holder;
  std::ostringstream notes;
  const std::string port = std::to_string(holder.port);
  EXPECT_THROW(start_handshake(parse({"--link-dir", dir_.c_str(), "--handshake-port", port.c_str()}), host_, "", notes),
               std::runtime_error);
  EXPECT_FALSE(std::filesystem::exists(dir_ + "/handshake.sock"));  // nothing left half set up
}

}  // namespace
}  // namespace doppel::gateway
