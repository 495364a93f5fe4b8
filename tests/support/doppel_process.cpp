#include "doppel_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "contract/access_token.h"

namespace doppel::testing {

std::string doppel_executable() {
  const char* chosen = std::getenv("DOPPEL_EXECUTABLE");
  return chosen != nullptr && *chosen != '\0' ? chosen : DOPPEL_EXECUTABLE;
}

std::pair<int, std::string> run_command(const std::string& command) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) {
    throw std::runtime_error("cannot run: " + command);
  }
  std::string output;
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe) != nullptr) {
    output += buffer;
  }
  const int status = ::pclose(pipe);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, output};
}

DoppelProcess::DoppelProcess(std::vector<std::string> args, const std::string& link_name, bool camera) {
  char dir_template[] = "/tmp/doppel-test-XXXXXX";
  if (mkdtemp(dir_template) == nullptr) {
    throw std::runtime_error("mkdtemp failed");
  }
  link_dir_ = std::string(dir_template) + "/links";
  output_file_ = std::string(dir_template) + "/output.txt";
  args.insert(args.begin(), doppel_executable());
  args.push_back("--link-dir");
  args.push_back(link_dir_);
  if (!camera) {
    args.push_back("--no-camera");
  }
  if (std::find(args.begin(), args.end(), "--viewer") == args.end()) {
    args.push_back("--no-viewer");  // tests run side by side: none takes the default control port
  }
  if (std::find(args.begin(), args.end(), "--handshake-port") == args.end()) {
    args.push_back("--no-handshake-tcp");  // nor the handshake's default port (its socket is in link_dir)
  }
  if (std::find(args.begin(), args.end(), "--state-dir") == args.end()) {
    args.push_back("--state-dir");
    args.push_back(std::string(dir_template) + "/state");
  }
  std::vector<char*> argv;
  for (std::string& arg : args) {
    argv.push_back(arg.data());
  }
  argv.push_back(nullptr);
  pid_ = fork();
  if (pid_ == 0) {
    int out = ::open(output_file_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(out, 1);
    dup2(out, 2);
    execv(argv[0], argv.data());
    _exit(127);
  }
  // 30 s, as wait_for_output: default starts (camera, RouDi) took up to 7.4 s at load average 29
  // (docs/benchmarks.md).
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (!std::filesystem::exists(link(link_name))) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("doppel exited before creating " + link(link_name) + ": " + output());
    }
    if (std::chrono::steady_clock::now() > deadline) {
      stop(SIGKILL);
      throw std::runtime_error("doppel did not create " + link(link_name) + " within 30 s: " + output());
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

DoppelProcess::~DoppelProcess() {
  if (pid_ > 0) {
    stop(SIGKILL);
  }
  std::error_code ignored;
  std::filesystem::remove_all(std::filesystem::path(link_dir_).parent_path(), ignored);
}

int DoppelProcess::stop(int signal) {
  if (pid_ <= 0) {
    return -1;
  }
  kill(pid_, signal);
  int status = 0;
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);  // a loaded machine's shutdown, not a hang
  while (waitpid(pid_, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid_, SIGKILL);  // a doppel that ignores SIGTERM is a failure the caller sees in `status`
      waitpid(pid_, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  pid_ = -1;
  return status;
}

std::string DoppelProcess::wait_for_output(const std::string& text) const {
  auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  std::string out = output();
  while (out.find(text) == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    out = output();
  }
  return out;
}

std::string DoppelProcess::output() const {
  std::ifstream in(output_file_);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string DoppelProcess::access_token(uint16_t port) const {
  return contract::find_access_token(link_dir_, port).value_or("");
}

}  // namespace doppel::testing
