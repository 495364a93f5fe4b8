#include "watched_doppel.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/inotify.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "doppel_process.h"

namespace doppel::testing {

WatchedDoppel::WatchedDoppel(std::vector<std::string> extra) {
  char dir_template[] = "/tmp/doppel-watched-XXXXXX";
  if (::mkdtemp(dir_template) == nullptr) throw std::runtime_error("mkdtemp failed");
  dir_ = dir_template;
  links_ = dir_ + "/links";
  if (::mkdir(links_.c_str(), 0700) != 0) throw std::runtime_error("mkdir " + links_);
  inotify_ = ::inotify_init1(IN_CLOEXEC | IN_NONBLOCK);
  if (inotify_ < 0 || ::inotify_add_watch(inotify_, links_.c_str(), IN_CREATE | IN_MOVED_TO) < 0) {
    throw std::runtime_error("inotify on " + links_);
  }
  std::vector<std::string> args{doppel_executable(), "--link-dir", links_, "--state-dir", dir_ + "/state",
                                "--viewer", "0", "--handshake-port", "0"};
  args.insert(args.end(), extra.begin(), extra.end());
  std::vector<char*> argv;
  for (std::string& arg : args) argv.push_back(arg.data());
  argv.push_back(nullptr);
  const std::string output = dir_ + "/output.txt";
  pid_ = ::fork();
  if (pid_ == 0) {
    const int out = ::open(output.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    ::dup2(out, 1);
    ::dup2(out, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
}

WatchedDoppel::~WatchedDoppel() {
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
  }
  if (inotify_ >= 0) ::close(inotify_);
  std::error_code ignored;
  std::filesystem::remove_all(dir_, ignored);
}

std::string WatchedDoppel::wait_for_link(const std::string& name, int guard_ms) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(guard_ms);
  alignas(inotify_event) std::array<char, 4096> events{};
  while (std::chrono::steady_clock::now() < deadline) {
    pollfd p{inotify_, POLLIN, 0};
    if (::poll(&p, 1, 50) > 0) {
      const ssize_t n = ::read(inotify_, events.data(), events.size());
      for (ssize_t offset = 0; offset < n;) {
        const auto* event = reinterpret_cast<const inotify_event*>(events.data() + offset);
        offset += static_cast<ssize_t>(sizeof(inotify_event) + event->len);
        if (event->len > 0 && name == event->name) return links_ + "/" + name;
      }
    }
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      throw std::runtime_error("doppel exited before " + name + " appeared: " + output());
    }
  }
  throw std::runtime_error(name + " did not appear: " + output());
}

std::vector<std::string> WatchedDoppel::thread_names() const {
  std::vector<std::string> names;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid_) + "/task")) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    std::getline(comm, name);
    names.push_back(name);
  }
  return names;
}

std::string WatchedDoppel::stop() {
  if (pid_ > 0) {
    ::kill(pid_, SIGTERM);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
  }
  return output();
}

std::string WatchedDoppel::output() const {
  std::ifstream in(dir_ + "/output.txt");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace doppel::testing
