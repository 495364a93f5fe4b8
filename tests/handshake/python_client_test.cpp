// programs/examples/handshake/doppel_session.py, run with Debian's /usr/bin/python3 and the handshake_pb2
// the build generated, against the server with a fake RobotHost whose robot's bus is a real
// pseudo-terminal that answers a Protocol 1.0 PING of ID 1 (golden bytes from the e-Manual's
// Protocol 1.0 page: instruction FF FF 01 02 01 FB, status FF FF 01 02 00 FC).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>

#include "fake_robot_host.h"
#include "contract/access_token.h"
#include "handshake/server.h"

namespace doppel::handshake {
namespace {

// A pty whose far end is a servo with ID 1 that answers PING.
class PingingPty {
 public:
  PingingPty() {
    if (openpty(&master_, &slave_, nullptr, nullptr, nullptr) != 0) {
      throw std::runtime_error("openpty failed");
    }
    termios t{};
    tcgetattr(slave_, &t);
    cfmakeraw(&t);
    tcsetattr(slave_, TCSANOW, &t);
    path_ = ttyname(slave_);
    thread_ = std::thread([this] { run(); });
  }
  ~PingingPty() {
    stop_ = true;
    thread_.join();
    close(master_);
    close(slave_);
  }
  const std::string& path() const { return path_; }
  int pings() const { return pings_.load(); }

 private:
  void run() {
    const std::string ping("\xFF\xFF\x01\x02\x01\xFB", 6);
    const std::string status("\xFF\xFF\x01\x02\x00\xFC", 6);
    std::string received;
    while (!stop_) {
      pollfd p{master_, POLLIN, 0};
      if (poll(&p, 1, 20) <= 0 || (p.revents & POLLIN) == 0) {
        continue;
      }
      char buffer[256];
      const ssize_t n = read(master_, buffer, sizeof buffer);
      if (n <= 0) {
        continue;
      }
      received.append(buffer, static_cast<std::size_t>(n));
      for (std::size_t at = received.find(ping); at != std::string::npos; at = received.find(ping)) {
        received.erase(0, at + ping.size());
        [[maybe_unused]] const ssize_t w = write(master_, status.data(), status.size());
        ++pings_;
      }
    }
  }

  int master_ = -1;
  int slave_ = -1;
  std::string path_;
  std::atomic<bool> stop_{false};
  std::atomic<int> pings_{0};
  std::thread thread_;
};

struct ClientRun {
  int exit_code;
  std::string output;
};

ClientRun run_client(const std::string& endpoint_args) {
  const std::string command = "/usr/bin/python3 " DOPPEL_SESSION_SCRIPT " --python-dir " DOPPEL_PYTHON_DIR " " +
                              endpoint_args + " --robot op3 --camera head --width 320 --height 240 --format yuyv"
                              " --world-model-fov 90 --world-model-sigma 0.05 --sensor-levels 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) {
    return {-1, "popen failed"};
  }
  ClientRun run{};
  char buffer[512];
  while (fgets(buffer, sizeof buffer, pipe) != nullptr) {
    run.output += buffer;
  }
  const int status = pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return run;
}

class PythonClient : public ::testing::TestWithParam<bool> {};

TEST_P(PythonClient, AddsPingsReattachesAndRemoves) {
  const bool tcp = GetParam();
  PingingPty bus;
  testing::FakeRobotHost host;
  host.links = [&bus](uint32_t robot) {
    return std::vector<contract::Link>{{"bus", "ttyDXL0", bus.path()},
                                      {"camera", "head", "iceoryx:DoppelCamera/head" + std::to_string(robot) + "/frames"}};
  };
  char pattern[] = "/tmp/doppel-handshake-py-XXXXXX";
  const std::string dir = mkdtemp(pattern);
  ServerOptions options;
  options.unix_path = dir + "/handshake.sock";
  options.tcp_port = 0;
  options.tcp_token = contract::new_access_token();  // as doppel serves TCP: the client finds it in the link directory
  Server server(host, options);
  std::optional<contract::TokenFile> token_file;
  token_file.emplace(contract::token_file_path(dir, server.tcp_port()), options.tcp_token);
  const ClientRun run = run_client(tcp ? "--tcp 127.0.0.1:" + std::to_string(server.tcp_port()) + " --link-dir " + dir
                                       : "--unix " + options.unix_path);
  server.stop();
  token_file.reset();
  std::filesystem::remove_all(dir);

  EXPECT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("added: robot 1 (op3)"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find(bus.path()), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("iceoryx:DoppelCamera/head1/frames"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("PING id 1 on " + bus.path() + ": answered, error byte 0x00"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("reattached: robot 1 (op3)"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("removed: robot 1"), std::string::npos) << run.output;
  EXPECT_EQ(bus.pings(), 1);
  ASSERT_EQ(host.add_calls, 1);
  const contract::RobotRequest request = host.requests().at(0);
  EXPECT_EQ(request.robot, "op3");
  ASSERT_EQ(request.cameras.size(), 1u);
  EXPECT_EQ(request.cameras[0].name, "head");
  EXPECT_EQ(request.cameras[0].width_px, 320u);
  EXPECT_EQ(request.cameras[0].height_px, 240u);
  EXPECT_EQ(request.cameras[0].format, "yuyv");
  ASSERT_TRUE(request.world_model);
  EXPECT_EQ(request.world_model->fov_deg, 90.0);
  EXPECT_EQ(request.world_model->position_sigma_m, 0.05);
  EXPECT_EQ(request.world_model->rate_hz, contract::WorldModelSettings{}.rate_hz);
  EXPECT_TRUE(request.sensor_levels);
  EXPECT_EQ(host.removed(), std::vector<uint32_t>{1});
}

TEST(PythonClientErrors, ARefusalNamesTheFieldAndExitsNonZero) {
  testing::FakeRobotHost host;
  char pattern[] = "/tmp/doppel-handshake-py-XXXXXX";
  const std::string dir = mkdtemp(pattern);
  ServerOptions options;
  options.unix_path = dir + "/handshake.sock";
  Server server(host, options);
  const std::string command = "/usr/bin/python3 " DOPPEL_SESSION_SCRIPT " --python-dir " DOPPEL_PYTHON_DIR
                              " --unix " + options.unix_path + " --robot op3 --camera head --width 9000 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  char buffer[512];
  while (fgets(buffer, sizeof buffer, pipe) != nullptr) {
    output += buffer;
  }
  const int status = pclose(pipe);
  server.stop();
  std::filesystem::remove_all(dir);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0) << output;
  EXPECT_NE(output.find("doppel refused: add_robot.camera[0].width_px: must be 2..8192, got 9000"), std::string::npos)
      << output;
  EXPECT_EQ(host.add_calls, 0);
}

INSTANTIATE_TEST_SUITE_P(Transports, PythonClient, ::testing::Values(false, true),
                         [](const auto& param) { return param.param ? "Tcp" : "Unix"; });

}  // namespace
}  // namespace doppel::handshake
