// The handshake server over a Unix socket and over TCP (loopback) against a fake RobotHost: every
// request kind, bad requests that call nothing, bytes no client should send, clients that vanish
// or never speak, reattach after a disconnect, several clients at once.
#include "handshake/server.h"

#include <google/protobuf/text_format.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/un.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "fake_robot_host.h"
#include "test_client.h"

namespace doppel::handshake {
namespace {

using testing::FakeRobotHost;
using testing::TestClient;
using namespace std::chrono_literals;

wire::ClientMessage request(const std::string& text) {
  wire::ClientMessage m;
  EXPECT_TRUE(google::protobuf::TextFormat::ParseFromString(text, &m)) << text;
  return m;
}

class TempDir {
 public:
  TempDir() {
    char pattern[] = "/tmp/doppel-handshake-XXXXXX";
    path_ = mkdtemp(pattern);
  }
  ~TempDir() { std::filesystem::remove_all(path_); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

enum class Transport { kUnix, kTcp };

class HandshakeServer : public ::testing::TestWithParam<Transport> {
 protected:
  void start(ServerOptions options = {}) {
    options.unix_path = dir_.path() + "/handshake.sock";
    options.tcp_port = 0;
    server_ = std::make_unique<Server>(host_, options);
  }
  // Timeouts far beyond what a loaded machine keeps a client thread waiting, so that only the tests
  // of the timeouts themselves (impatient()) meet them.
  void SetUp() override { start(with_timeouts(10s)); }
  // The server again with 400 ms timeouts (first request, frame, write), for the tests of them.
  void impatient() {
    server_.reset();
    start(with_timeouts(400ms));
  }
  static ServerOptions with_timeouts(std::chrono::milliseconds timeout) {
    ServerOptions options;
    options.first_request_timeout = timeout;
    options.frame_timeout = timeout;
    options.max_frame_bytes = 4096;
    options.write_timeout = timeout;
    return options;
  }
  TestClient connect() {
    return GetParam() == Transport::kUnix ? TestClient::unix_socket(server_->unix_path())
                                          : TestClient::tcp(server_->tcp_port());
  }
  // A client that works: the server is still serving.
  void expect_serving() {
    TestClient c = connect();
    const wire::ServerMessage reply = c.call(request("list_robots {}"));
    EXPECT_TRUE(reply.has_robot_list()) << reply.ShortDebugString();
  }

  TempDir dir_;
  FakeRobotHost host_;
  std::unique_ptr<Server> server_;
};

TEST_P(HandshakeServer, AddsListsReattachesAndRemovesARobot) {
  std::string token;
  {
    TestClient c = connect();
    const wire::ServerMessage added = c.call(request(R"(add_robot { robot: "op3" x_m: 1 team: 1
        camera { name: "head" width_px: 320 height_px: 240 format: "yuyv" } world_model { fov_deg: 90 } })"));
    ASSERT_TRUE(added.has_robot_added()) << added.ShortDebugString();
    EXPECT_EQ(added.robot_added().robot(), 1u);
    EXPECT_EQ(added.robot_added().name(), "op3");
    token = added.robot_added().token();
    EXPECT_EQ(token.size(), 32u);
    EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos);
    ASSERT_EQ(added.robot_added().link_size(), 2);
    EXPECT_EQ(added.robot_added().link(0).kind(), "bus");
    EXPECT_EQ(added.robot_added().link(0).location(), "/links/robot1/ttyDXL0");
    EXPECT_EQ(added.robot_added().link(1).location(), "iceoryx:DoppelCamera/head1/frames");
    ASSERT_EQ(host_.add_calls, 1);
    const contract::RobotRequest r = host_.requests().at(0);
    EXPECT_EQ(r.robot, "op3");
    EXPECT_EQ(r.x_m, 1.0);
    EXPECT_EQ(r.team, 1u);
    ASSERT_EQ(r.cameras.size(), 1u);
    EXPECT_EQ(r.cameras[0].width_px, 320u);
    EXPECT_EQ(r.cameras[0].format, "yuyv");
    ASSERT_TRUE(r.world_model);
    EXPECT_EQ(r.world_model->fov_deg, 90.0);

    const wire::ServerMessage list = c.call(request("list_robots {}"));
    ASSERT_TRUE(list.has_robot_list());
    ASSERT_EQ(list.robot_list().robot_size(), 2);
    EXPECT_EQ(list.robot_list().robot(1).name(), "op3");
    EXPECT_TRUE(list.robot_list().robot(1).token().empty());  // a token only to its own client
  }  // the client goes; its robot stays
  EXPECT_EQ(host_.remove_calls, 0);

  TestClient again = connect();
  wire::ClientMessage reattach;
  reattach.mutable_reattach()->set_token(token);
  const wire::ServerMessage back = again.call(reattach);
  ASSERT_TRUE(back.has_reattached()) << back.ShortDebugString();
  EXPECT_EQ(back.reattached().robot(), 1u);
  EXPECT_EQ(back.reattached().token(), token);
  ASSERT_EQ(back.reattached().link_size(), 2);
  EXPECT_EQ(back.reattached().link(0).location(), "/links/robot1/ttyDXL0");

  const wire::ServerMessage removed = again.call(request("remove_robot { robot: 1 }"));
  ASSERT_TRUE(removed.has_removed()) << removed.ShortDebugString();
  EXPECT_EQ(removed.removed().robot(), 1u);
  EXPECT_EQ(host_.removed(), std::vector<uint32_t>{1});
  const wire::ServerMessage gone = again.call(reattach);
  ASSERT_TRUE(gone.has_error());
  EXPECT_EQ(gone.error().field(), "reattach.token");
  EXPECT_EQ(again.call(request("list_robots {}")).robot_list().robot_size(), 1);
  EXPECT_EQ(host_.add_calls, 1);
}

TEST_P(HandshakeServer, ABadRequestNamesItsFieldCallsNothingAndKeepsTheConnection) {
  TestClient c = connect();
  const wire::ServerMessage reply =
      c.call(request(R"(add_robot { robot: "op3" camera { name: "head" } camera { name: "eye" width_px: 0 } })"));
  ASSERT_TRUE(reply.has_error()) << reply.ShortDebugString();
  EXPECT_EQ(reply.error().field(), "add_robot.camera[1].width_px");
  EXPECT_NE(reply.error().message().find("2..8192"), std::string::npos);
  EXPECT_EQ(host_.add_calls, 0);
  const wire::ServerMessage both = c.call(request(R"(add_robot { robot: "op3" description: "name: \"x\"" })"));
  EXPECT_EQ(both.error().field(), "add_robot.robot");
  EXPECT_EQ(host_.add_calls, 0);
  EXPECT_TRUE(c.call(request("list_robots {}")).has_robot_list());
}

TEST_P(HandshakeServer, TheHostsRefusalNamesTheProtoField) {
  host_.refuse_next_add = contract::Refusal{"cameras[0].noise_gaussian_sigma", "the robot has no camera 'eye'"};
  TestClient c = connect();
  const wire::ServerMessage reply = c.call(request(R"(add_robot { robot: "op3" camera { name: "eye" } })"));
  ASSERT_TRUE(reply.has_error());
  EXPECT_EQ(reply.error().field(), "add_robot.camera[0].noise.gaussian_sigma");
  EXPECT_EQ(reply.error().message(), "the robot has no camera 'eye'");
  EXPECT_EQ(c.call(request("list_robots {}")).robot_list().robot_size(), 1);  // nothing half-built

  const wire::ServerMessage no_such = c.call(request("remove_robot { robot: 9 }"));
  ASSERT_TRUE(no_such.has_error());
  EXPECT_EQ(no_such.error().field(), "remove_robot.robot");
  EXPECT_EQ(no_such.error().message(), "there is no robot 9");

  wire::ClientMessage reattach;
  reattach.mutable_reattach()->set_token("0123456789abcdef0123456789abcdef");
  EXPECT_EQ(c.call(reattach).error().field(), "reattach.token");
  reattach.mutable_reattach()->set_token("");
  EXPECT_EQ(c.call(reattach).error().field(), "reattach.token");
}

TEST_P(HandshakeServer, AnEmptyMessageIsAnErrorAndTheConnectionStays) {
  TestClient c = connect();
  c.send_raw(TestClient::frame(""));
  const auto reply = c.receive();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_EQ(reply->error().field(), "");
  EXPECT_NE(reply->error().message().find("empty request"), std::string::npos);
  EXPECT_TRUE(c.call(request("list_robots {}")).has_robot_list());
}

TEST_P(HandshakeServer, RequestsSentTogetherAreAnsweredInOrder) {
  TestClient c = connect();
  c.send_raw(TestClient::frame(request("list_robots {}").SerializeAsString()) +
             TestClient::frame(request(R"(add_robot { robot: "op3" })").SerializeAsString()) +
             TestClient::frame(request("remove_robot { robot: 1 }").SerializeAsString()));
  const auto first = c.receive();
  const auto second = c.receive();
  const auto third = c.receive();
  ASSERT_TRUE(first && second && third);
  EXPECT_TRUE(first->has_robot_list());
  EXPECT_TRUE(second->has_robot_added());
  EXPECT_TRUE(third->has_removed());
}

TEST_P(HandshakeServer, GarbageGetsAnErrorThenTheConnectionCloses) {
  TestClient c = connect();
  c.send_raw(TestClient::frame("\xff\xff\xff\xff\xff\xff"));  // field 0x1FFFFFFF... : not a protobuf message
  const auto reply = c.receive();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_NE(reply->error().message().find("not a ClientMessage"), std::string::npos) << reply->error().message();
  EXPECT_TRUE(c.closed_by_server());
  EXPECT_EQ(host_.add_calls + host_.remove_calls + host_.robots_calls, 0);
  expect_serving();
}

TEST_P(HandshakeServer, AnOversizedLengthGetsAnErrorThenTheConnectionCloses) {
  for (const std::string& prefix : {std::string("\xff\xff\xff\xff", 4), std::string("\x01\x10\x00\x00", 4)}) {
    TestClient c = connect();  // 0xFFFFFFFF, and 4097: one above this server's maximum of 4096
    c.send_raw(prefix);
    const auto reply = c.receive();
    ASSERT_TRUE(reply && reply->has_error());
    EXPECT_NE(reply->error().message().find("exceeds the maximum of 4096"), std::string::npos) << reply->error().message();
    EXPECT_TRUE(c.closed_by_server());
  }
  TestClient at_limit = connect();  // 4096 is allowed: an AddRobot with a 4 KB description
  wire::ClientMessage big;
  big.mutable_add_robot()->set_description(std::string(4096 - 8, 'x'));
  const std::string payload = big.SerializeAsString();
  ASSERT_LE(payload.size(), 4096u);
  ASSERT_GT(payload.size(), 4080u);
  EXPECT_TRUE(at_limit.call(big).has_robot_added());
  expect_serving();
}

TEST_P(HandshakeServer, ATruncatedFrameTimesOutWithAnError) {
  impatient();
  TestClient c = connect();
  c.send_raw(std::string("\x64\x00\x00\x00", 4) + "0123456789");  // 100 announced, 10 sent
  const auto reply = c.receive();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_NE(reply->error().message().find("did not arrive whole"), std::string::npos) << reply->error().message();
  EXPECT_TRUE(c.closed_by_server());
  EXPECT_EQ(host_.add_calls, 0);
}

TEST_P(HandshakeServer, AClientThatNeverSpeaksIsClosed) {
  impatient();
  TestClient c = connect();
  const auto reply = c.receive();
  ASSERT_TRUE(reply && reply->has_error());
  EXPECT_NE(reply->error().message().find("no request within"), std::string::npos) << reply->error().message();
  EXPECT_TRUE(c.closed_by_server());
}

TEST_P(HandshakeServer, AClientThatSpokeMayStayIdle) {
  impatient();
  TestClient c = connect();
  EXPECT_TRUE(c.call(request("list_robots {}")).has_robot_list());
  EXPECT_FALSE(c.receive(1500ms));  // well past the first-request timeout: no error, not closed
  EXPECT_TRUE(c.call(request("list_robots {}")).has_robot_list());
}

TEST_P(HandshakeServer, AClientThatReadsNoRepliesIsClosed) {
  impatient();
  TestClient c = connect();
  const std::string one = TestClient::frame(request("list_robots {}").SerializeAsString());
  std::string many;
  for (int i = 0; i < 256; ++i) {
    many += one;
  }
  // Requests until neither the server's replies nor the requests fit the socket buffers any more.
  const std::size_t sent = c.flood(many, 64u << 20);
  EXPECT_LT(sent, 64u << 20);
  EXPECT_TRUE(c.write_refused());  // the server gave up on its reply (write_timeout) and closed
  expect_serving();
}

TEST_P(HandshakeServer, AClientThatVanishesMidFrameLeavesNothingBehind) {
  for (int i = 0; i < 20; ++i) {
    TestClient c = connect();
    const std::string frame = TestClient::frame(request(R"(add_robot { robot: "op3" })").SerializeAsString());
    c.send_raw(frame.substr(0, static_cast<std::size_t>(i) % frame.size()));
  }
  expect_serving();
  EXPECT_EQ(host_.add_calls, 0);
}

TEST_P(HandshakeServer, TwoClientsAtOnceEachGetTheirOwnAnswers) {
  TestClient a = connect();
  TestClient b = connect();
  const auto added_a = a.call(request(R"(add_robot { robot: "op3" })"));
  const auto added_b = b.call(request(R"(add_robot { robot: "wolfgang" cameras_off: true })"));
  ASSERT_TRUE(added_a.has_robot_added() && added_b.has_robot_added());
  EXPECT_EQ(added_a.robot_added().name(), "op3");
  EXPECT_EQ(added_b.robot_added().name(), "wolfgang");
  EXPECT_NE(added_a.robot_added().robot(), added_b.robot_added().robot());
  EXPECT_NE(added_a.robot_added().token(), added_b.robot_added().token());
  // At the same moment, from two threads, a silent third client in between.
  TestClient silent = connect();
  std::vector<wire::ServerMessage> replies_a, replies_b;
  std::thread ta([&] {
    for (int i = 0; i < 20; ++i) replies_a.push_back(a.call(request("list_robots {}")));
  });
  std::thread tb([&] {
    for (int i = 0; i < 20; ++i) replies_b.push_back(b.call(request(R"(add_robot { robot: "op3" cameras_off: true })")));
  });
  ta.join();
  tb.join();
  for (const auto& r : replies_a) EXPECT_TRUE(r.has_robot_list());
  for (const auto& r : replies_b) EXPECT_TRUE(r.has_robot_added());
  EXPECT_EQ(host_.add_calls, 22);
  EXPECT_EQ(a.call(request("list_robots {}")).robot_list().robot_size(), 23);
}

TEST_P(HandshakeServer, StopsWithClientsConnected) {
  TestClient idle = connect();
  TestClient mid_frame = connect();
  mid_frame.send_raw(std::string("\x10\x00", 2));
  server_->stop();
  EXPECT_TRUE(idle.closed_by_server());
  EXPECT_TRUE(mid_frame.closed_by_server());
  server_->stop();  // idempotent
}

INSTANTIATE_TEST_SUITE_P(Transports, HandshakeServer, ::testing::Values(Transport::kUnix, Transport::kTcp),
                         [](const auto& param) { return param.param == Transport::kUnix ? "Unix" : "Tcp"; });

TEST(HandshakeServerLimits, ClientsBeyondTheMaximumAreTurnedAwayWithAnError) {
  TempDir dir;
  FakeRobotHost host;
  ServerOptions options;
  options.unix_path = dir.path() + "/h.sock";
  options.max_clients = 2;
  Server server(host, options);
  std::optional<TestClient> a(TestClient::unix_socket(options.unix_path));
  TestClient b = TestClient::unix_socket(options.unix_path);
  EXPECT_TRUE(a->call(request("list_robots {}")).has_robot_list());
  EXPECT_TRUE(b.call(request("list_robots {}")).has_robot_list());
  TestClient c = TestClient::unix_socket(options.unix_path);
  const auto refused = c.receive();
  ASSERT_TRUE(refused && refused->has_error());
  EXPECT_NE(refused->error().message().find("serves 2 handshake clients already"), std::string::npos);
  EXPECT_TRUE(c.closed_by_server());
  a.reset();  // one leaves: there is room again once the server has seen it go
  bool served = false;
  for (int attempt = 0; attempt < 200 && !served; ++attempt) {
    TestClient d = TestClient::unix_socket(options.unix_path);
    try {
      d.send(request("list_robots {}"));  // fails while the server still counts `a` and has closed d
      const auto reply = d.receive();
      served = reply && reply->has_robot_list();
    } catch (const std::runtime_error&) {
      served = false;
    }
    if (!served) {
      std::this_thread::sleep_for(50ms);
    }
  }
  EXPECT_TRUE(served);
}

TEST(HandshakeServerSocket, IsPrivateReplacesAStaleSocketRefusesALiveOneAndGoesAtStop) {
  TempDir dir;
  FakeRobotHost host;
  ServerOptions options;
  options.unix_path = dir.path() + "/handshake.sock";
  {
    // A socket file left by a doppel that was killed: nobody listens.
    const int stale = socket(AF_UNIX, SOCK_STREAM, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, options.unix_path.c_str(), sizeof address.sun_path - 1);
    ASSERT_EQ(bind(stale, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
    close(stale);
    ASSERT_TRUE(std::filesystem::is_socket(options.unix_path));
  }
  {
    Server server(host, options);
    struct stat st{};
    ASSERT_EQ(lstat(options.unix_path.c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0600u);
    EXPECT_TRUE(TestClient::unix_socket(options.unix_path).call(request("list_robots {}")).has_robot_list());
    try {
      Server second(host, options);
      ADD_FAILURE() << "a second server took a live socket";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find("listens on it"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(TestClient::unix_socket(options.unix_path).call(request("list_robots {}")).has_robot_list());
  }
  EXPECT_FALSE(std::filesystem::exists(options.unix_path));
  std::ofstream(options.unix_path) << "not a socket";
  try {
    Server server(host, options);
    ADD_FAILURE() << "served on a regular file's path";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not a socket"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::is_regular_file(options.unix_path));  // left alone
}

TEST(HandshakeServerSocket, RefusesWhatItCannotServe) {
  FakeRobotHost host;
  ServerOptions options;
  options.tcp_port = 0;
  options.tcp_address = "localhost";  // a name, not an address: it would depend on the resolver
  EXPECT_THROW(Server(host, options), std::runtime_error);
  options.tcp_port.reset();
  EXPECT_THROW(Server(host, options), std::invalid_argument);  // nothing to serve
  options.unix_path = "/tmp/" + std::string(120, 'x');
  EXPECT_THROW(Server(host, options), std::runtime_error);
  options.unix_path.clear();
  options.tcp_port = 0;
  options.tcp_address = "::1";
  try {
    Server v6(host, options);
    EXPECT_NE(v6.tcp_port(), 0);
    EXPECT_NE(v6.describe().find("tcp [::1]:"), std::string::npos) << v6.describe();
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "no IPv6 loopback here: " << e.what();
  }
}

TEST(HandshakeServerSocket, ATakenPortIsAnError) {
  FakeRobotHost host;
  ServerOptions options;
  options.tcp_port = 0;
  Server first(host, options);
  options.tcp_port = first.tcp_port();
  try {
    Server second(host, options);
    ADD_FAILURE() << "two servers on port " << first.tcp_port();
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("port " + std::to_string(first.tcp_port())), std::string::npos) << e.what();
  }
}


// With the run's access token (docs/security.md), TCP needs it in every message: none or a wrong
// one gets an Error for "access_token", the connection closes and the host is never asked; the
// Unix socket, private by its mode, needs none.
TEST(HandshakeAccessToken, TcpNeedsTheTokenTheUnixSocketDoesNot) {
  TempDir dir;
  FakeRobotHost host;
  ServerOptions options;
  options.unix_path = dir.path() + "/handshake.sock";
  options.tcp_port = 0;
  options.tcp_token = "0123456789abcdef0123456789abcdef";
  Server server(host, options);
  const std::string add = R"(add_robot { robot: "op3" })";
  for (const std::string& offered : {std::string(), std::string("0123456789abcdef0123456789abcdee"), std::string("x")}) {
    TestClient c = TestClient::tcp(server.tcp_port());
    wire::ClientMessage m = request(add);
    m.set_access_token(offered);
    const wire::ServerMessage reply = c.call(m);
    ASSERT_TRUE(reply.has_error()) << reply.ShortDebugString();
    EXPECT_EQ(reply.error().field(), "access_token");
    EXPECT_FALSE(c.receive(2s).has_value()) << "the connection stays open after a wrong token";
  }
  EXPECT_EQ(host.add_calls, 0);
  EXPECT_EQ(host.robots_calls, 0);

  TestClient good = TestClient::tcp(server.tcp_port());
  wire::ClientMessage list = request("list_robots {}");
  list.set_access_token(options.tcp_token);
  EXPECT_TRUE(good.call(list).has_robot_list());
  wire::ClientMessage added = request(add);
  added.set_access_token(options.tcp_token);
  EXPECT_TRUE(good.call(added).has_robot_added());
  // A later message of the same connection without it is refused as well.
  EXPECT_EQ(good.call(request("list_robots {}")).error().field(), "access_token");

  TestClient local = TestClient::unix_socket(server.unix_path());
  EXPECT_TRUE(local.call(request("list_robots {}")).has_robot_list());
}

}  // namespace
}  // namespace doppel::handshake
