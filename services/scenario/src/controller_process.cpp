#include "controller_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <thread>

namespace doppel::scenario {
namespace {

bool executable_file(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode) && ::access(path.c_str(), X_OK) == 0;
}

std::string tail_of(const std::string& path, std::size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  const std::streamoff from = size > static_cast<std::streamoff>(bytes) ? size - static_cast<std::streamoff>(bytes) : 0;
  in.seekg(from);
  std::string text(static_cast<std::size_t>(size - from), '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (from > 0) {
    if (const std::size_t newline = text.find('\n'); newline != std::string::npos && newline + 1 < text.size()) {
      text.erase(0, newline + 1);
    }
  }
  return text;
}

}  // namespace

std::string find_program(const std::string& name, const std::string& folder, const std::vector<std::string>& tool_dirs) {
  if (name.find('/') != std::string::npos) {
    std::filesystem::path path(name);
    if (path.is_relative()) path = std::filesystem::path(folder) / path;
    return executable_file(path.string()) ? path.string() : std::string();
  }
  std::vector<std::string> dirs = tool_dirs;
  if (const char* env = std::getenv("PATH"); env != nullptr) {
    std::string list = env;
    std::size_t at = 0;
    while (at <= list.size()) {
      const std::size_t colon = list.find(':', at);
      dirs.push_back(list.substr(at, colon == std::string::npos ? std::string::npos : colon - at));
      if (colon == std::string::npos) break;
      at = colon + 1;
    }
  }
  for (const std::string& dir : dirs) {
    if (dir.empty()) continue;
    const std::string path = dir + "/" + name;
    if (executable_file(path)) return path;
  }
  return "";
}

ControllerProcess::ControllerProcess(const std::vector<std::string>& argv, const std::string& output_prefix)
    : stdout_path_(output_prefix + ".stdout"), stderr_path_(output_prefix + ".stderr") {
  if (argv.empty()) throw std::runtime_error("no controller command");
  std::vector<char*> args;
  for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  const int out = ::open(stdout_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  const int err = ::open(stderr_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  int report[2] = {-1, -1};  // the child writes errno here when exec fails; closed by a good exec
  if (out < 0 || err < 0 || ::pipe2(report, O_CLOEXEC) != 0) {
    const int error = errno;
    if (out >= 0) ::close(out);
    if (err >= 0) ::close(err);
    throw std::runtime_error("cannot set up the controller's output files: " + std::string(std::strerror(error)));
  }
  sigset_t none;
  sigemptyset(&none);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::setpgid(0, 0);
    ::sigprocmask(SIG_SETMASK, &none, nullptr);  // the parent blocks SIGINT/SIGTERM for its signal thread
    ::signal(SIGPIPE, SIG_DFL);
    const int in = ::open("/dev/null", O_RDONLY);
    if (in >= 0) ::dup2(in, 0);
    ::dup2(out, 1);
    ::dup2(err, 2);
    ::execv(args[0], args.data());
    const int error = errno;
    (void)!::write(report[1], &error, sizeof error);
    ::_exit(127);
  }
  const int fork_error = errno;
  ::close(out);
  ::close(err);
  ::close(report[1]);
  if (pid < 0) {
    ::close(report[0]);
    throw std::runtime_error("cannot start the controller " + argv[0] + ": fork: " + std::strerror(fork_error));
  }
  ::setpgid(pid, pid);  // also from here: no race with a kill before the child ran setpgid
  pid_ = pid;
  running_ = true;
  int error = 0;
  ssize_t got;
  do {
    got = ::read(report[0], &error, sizeof error);
  } while (got < 0 && errno == EINTR);
  ::close(report[0]);
  if (got == static_cast<ssize_t>(sizeof error)) {
    int status = 0;
    ::waitpid(pid_, &status, 0);
    running_ = false;
    throw std::runtime_error("cannot start the controller " + argv[0] + ": " + std::strerror(error));
  }
}

ControllerProcess::~ControllerProcess() { stop(); }

void ControllerProcess::record(int status) noexcept {
  running_ = false;
  if (WIFEXITED(status)) exit_code_ = WEXITSTATUS(status);
  if (WIFSIGNALED(status)) signal_ = WTERMSIG(status);
}

bool ControllerProcess::exited() {
  if (!running_) return true;
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) == pid_) {
    record(status);
  }
  return !running_;
}

void ControllerProcess::stop(int grace_ms) {
  if (pid_ <= 0) return;
  if (!exited()) {
    stopped_by_us_ = true;
    ::kill(-pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(grace_ms);
    while (!exited() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (!exited()) {
      ::kill(-pid_, SIGKILL);
      int status = 0;
      if (::waitpid(pid_, &status, 0) == pid_) record(status);
    }
  }
  ::kill(-pid_, SIGKILL);  // whatever it started and left behind in its group
  pid_ = -1;
}

std::string ControllerProcess::stderr_tail(std::size_t bytes) const { return tail_of(stderr_path_, bytes); }
std::string ControllerProcess::stdout_tail(std::size_t bytes) const { return tail_of(stdout_path_, bytes); }

}  // namespace doppel::scenario
