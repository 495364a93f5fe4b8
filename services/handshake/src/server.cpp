#include "handshake/server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <exception>
#include <list>
#include <stdexcept>
#include <thread>
#include <variant>

#include "contract/access_token.h"
#include "handshake/request.h"

namespace doppel::handshake {
namespace {

using Clock = std::chrono::steady_clock;

std::string error_text(int error) { return std::strerror(error); }

wire::ServerMessage error_reply(std::string field, std::string message) {
  wire::ServerMessage reply;
  wire::Error* e = reply.mutable_error();
  e->set_field(std::move(field));
  e->set_message(std::move(message));
  return reply;
}

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
  return left <= 0 ? 0 : static_cast<int>(std::min<long long>(left, 1 << 30));
}

double seconds(std::chrono::milliseconds d) { return static_cast<double>(d.count()) / 1000.0; }

std::string seconds_text(std::chrono::milliseconds d) {
  std::string s = std::to_string(seconds(d));
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') {
    s.pop_back();
  }
  return s + " s";
}

}  // namespace

wire::ServerMessage Sessions::handle(const wire::ClientMessage& request) {
  try {
    switch (request.kind_case()) {
      case wire::ClientMessage::kAddRobot:
        return add(request.add_robot());
      case wire::ClientMessage::kRemoveRobot:
        return remove(request.remove_robot());
      case wire::ClientMessage::kReattach:
        return reattach(request.reattach());
      case wire::ClientMessage::kListRobots:
        return list();
      case wire::ClientMessage::KIND_NOT_SET:
        break;
    }
  } catch (const std::exception& e) {
    return error_reply("", std::string("doppel failed: ") + e.what());
  }
  return error_reply("", "empty request: set one of add_robot, remove_robot, reattach, list_robots");
}

wire::ServerMessage Sessions::add(const wire::AddRobot& message) {
  auto checked = check_add_robot(message);
  if (const auto* refusal = std::get_if<contract::Refusal>(&checked)) {
    return error_reply(refusal->field, refusal->message);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  contract::AddResult result = host_.add_robot(std::get<contract::RobotRequest>(checked));
  if (const auto* refusal = std::get_if<contract::Refusal>(&result)) {
    return error_reply(proto_field_path(refusal->field), refusal->message);
  }
  const auto& added = std::get<contract::RobotAdded>(result);
  std::string token = contract::new_access_token();  // a capability, not a counter a neighbour could guess
  tokens_[token] = Owned{added.robot, added.name};
  wire::ServerMessage reply;
  *reply.mutable_robot_added() = to_wire(added);
  reply.mutable_robot_added()->set_token(token);
  return reply;
}

wire::ServerMessage Sessions::remove(const wire::RemoveRobot& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (std::optional<contract::Refusal> refusal = host_.remove_robot(message.robot())) {
    return error_reply("remove_robot.robot", refusal->message);
  }
  std::erase_if(tokens_, [&](const auto& entry) { return entry.second.robot == message.robot(); });
  wire::ServerMessage reply;
  reply.mutable_removed()->set_robot(message.robot());
  return reply;
}

wire::ServerMessage Sessions::reattach(const wire::Reattach& message) {
  if (message.token().empty()) {
    return error_reply("reattach.token", "must be the token robot_added gave");
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = tokens_.find(message.token());
  if (found == tokens_.end()) {
    return error_reply("reattach.token", "no robot has this token (removed, or added in another doppel run)");
  }
  for (const contract::RobotAdded& robot : host_.robots()) {
    if (robot.robot == found->second.robot && robot.name == found->second.name) {
      wire::ServerMessage reply;
      *reply.mutable_reattached() = to_wire(robot);
      reply.mutable_reattached()->set_token(message.token());
      return reply;
    }
  }
  const std::string what = "robot " + std::to_string(found->second.robot) + " (" + found->second.name +
                           ") is no longer served";
  tokens_.erase(found);
  return error_reply("reattach.token", what);
}

wire::ServerMessage Sessions::list() {
  std::lock_guard<std::mutex> lock(mutex_);
  wire::ServerMessage reply;
  wire::RobotList* list = reply.mutable_robot_list();
  for (const contract::RobotAdded& robot : host_.robots()) {
    *list->add_robot() = to_wire(robot);
  }
  return reply;
}

struct Server::Impl {
  struct Connection {
    int fd = -1;
    bool tcp = false;  // needs options.tcp_token
    std::thread thread;
    std::atomic<bool> done{false};
  };

  Impl(contract::RobotHost& host, ServerOptions o) : options(std::move(o)), sessions(host) {}

  ServerOptions options;
  Sessions sessions;
  int unix_fd = -1;
  int tcp_fd = -1;
  uint16_t port = 0;
  std::string unix_path;
  ino_t unix_inode = 0;
  int wake[2] = {-1, -1};  // written once by stop(); stays readable, so every thread's poll sees it
  std::thread listener;
  std::mutex mutex;
  std::list<Connection> clients;
  bool stopped = false;

  void open_unix();
  void open_tcp();
  void listen_loop() noexcept;
  void accept_one(int listen_fd) noexcept;
  void serve(Connection& c) noexcept;
  bool send_message(int fd, const wire::ServerMessage& message) noexcept;
  void reap(bool all) noexcept;
  void close_all() noexcept;
};

void Server::Impl::open_unix() {
  const std::string& path = options.unix_path;
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.size() >= sizeof address.sun_path) {
    throw std::runtime_error("handshake socket " + path + ": the path is longer than " +
                             std::to_string(sizeof address.sun_path - 1) + " bytes");
  }
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  struct stat st{};
  if (lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) {
      throw std::runtime_error("handshake socket " + path + ": exists and is not a socket");
    }
    const int probe = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const bool live = probe >= 0 && connect(probe, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    const int probe_error = errno;
    if (probe >= 0) {
      close(probe);
    }
    if (live) {
      throw std::runtime_error("handshake socket " + path + ": another program (a running doppel?) listens on it");
    }
    if (probe_error != ECONNREFUSED) {
      throw std::runtime_error("handshake socket " + path + ": cannot check the old socket: " + error_text(probe_error));
    }
    unlink(path.c_str());  // stale: its doppel is gone
  }
  unix_fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (unix_fd < 0 || bind(unix_fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    throw std::runtime_error("handshake socket " + path + ": " + error_text(errno));
  }
  chmod(path.c_str(), 0600);
  if (lstat(path.c_str(), &st) == 0) {
    unix_inode = st.st_ino;
  }
  if (listen(unix_fd, 16) != 0) {
    throw std::runtime_error("handshake socket " + path + ": " + error_text(errno));
  }
  unix_path = path;
}

void Server::Impl::open_tcp() {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICHOST | AI_PASSIVE | AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string where = options.tcp_address + " port " + std::to_string(*options.tcp_port);
  if (const int rc = getaddrinfo(options.tcp_address.c_str(), std::to_string(*options.tcp_port).c_str(), &hints, &found);
      rc != 0) {
    throw std::runtime_error("handshake address " + options.tcp_address + ": not a numeric IP address (" +
                             gai_strerror(rc) + ")");
  }
  std::unique_ptr<addrinfo, decltype(&freeaddrinfo)> owned(found, freeaddrinfo);
  tcp_fd = socket(found->ai_family, found->ai_socktype | SOCK_CLOEXEC, found->ai_protocol);
  if (tcp_fd < 0) {
    throw std::runtime_error("handshake " + where + ": " + error_text(errno));
  }
  const int one = 1;
  setsockopt(tcp_fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (bind(tcp_fd, found->ai_addr, found->ai_addrlen) != 0 || listen(tcp_fd, 16) != 0) {
    throw std::runtime_error("handshake " + where + ": " + error_text(errno));
  }
  sockaddr_storage bound{};
  socklen_t length = sizeof bound;
  getsockname(tcp_fd, reinterpret_cast<sockaddr*>(&bound), &length);
  port = ntohs(bound.ss_family == AF_INET6 ? reinterpret_cast<sockaddr_in6*>(&bound)->sin6_port
                                           : reinterpret_cast<sockaddr_in*>(&bound)->sin_port);
}

void Server::Impl::listen_loop() noexcept {
  while (true) {
    pollfd fds[3] = {{wake[0], POLLIN, 0}, {unix_fd, POLLIN, 0}, {tcp_fd, POLLIN, 0}};
    const int n = poll(fds, 3, 1000);  // wakes once a second to join finished clients
    if (n < 0 && errno != EINTR) {
      return;
    }
    if (fds[0].revents != 0) {
      return;
    }
    for (int i = 1; i < 3; ++i) {
      if (fds[i].fd >= 0 && (fds[i].revents & POLLIN) != 0) {
        accept_one(fds[i].fd);
      }
    }
    reap(false);
  }
}

void Server::Impl::accept_one(int listen_fd) noexcept {
  const int fd = accept4(listen_fd, nullptr, nullptr, SOCK_CLOEXEC);
  if (fd < 0) {
    if (errno == EMFILE || errno == ENFILE || errno == ENOBUFS || errno == ENOMEM) {
      std::this_thread::sleep_for(std::chrono::milliseconds(100));  // out of descriptors: do not spin
    }
    return;
  }
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);  // fails harmlessly on a Unix socket
  try {
    std::lock_guard<std::mutex> lock(mutex);
    int active = 0;
    for (const Connection& c : clients) {
      active += c.done.load() ? 0 : 1;
    }
    if (active >= options.max_clients) {
      const std::string frame = encode_frame(
          error_reply("", "doppel serves " + std::to_string(options.max_clients) + " handshake clients already; try later")
              .SerializeAsString());
      [[maybe_unused]] const ssize_t sent = send(fd, frame.data(), frame.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
      close(fd);
      return;
    }
    Connection& c = clients.emplace_back();
    c.fd = fd;
    c.tcp = listen_fd == tcp_fd;
    c.thread = std::thread([this, &c] { serve(c); });
  } catch (const std::exception&) {
    // No memory or no thread for it: the client is turned away, the server keeps running.
    std::lock_guard<std::mutex> lock(mutex);
    if (!clients.empty() && clients.back().fd == fd && !clients.back().thread.joinable()) {
      clients.pop_back();
    }
    close(fd);
  }
}

bool Server::Impl::send_message(int fd, const wire::ServerMessage& message) noexcept {
  std::string frame;
  try {
    frame = encode_frame(message.SerializeAsString());
  } catch (const std::exception&) {
    return false;
  }
  const Clock::time_point deadline = Clock::now() + options.write_timeout;
  std::size_t sent = 0;
  while (sent < frame.size()) {
    const ssize_t n = send(fd, frame.data() + sent, frame.size() - sent, MSG_DONTWAIT | MSG_NOSIGNAL);
    if (n > 0) {
      sent += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) {
      return false;
    }
    pollfd fds[2] = {{fd, POLLOUT, 0}, {wake[0], POLLIN, 0}};
    const int ready = poll(fds, 2, remaining_ms(deadline));
    if (ready == 0 || fds[1].revents != 0 || (fds[0].revents & (POLLERR | POLLHUP)) != 0) {
      return false;  // the client does not read its replies, or doppel stops
    }
  }
  return true;
}

void Server::Impl::serve(Connection& c) noexcept {
  FrameDecoder decoder(options.max_frame_bytes);
  const Clock::time_point connected = Clock::now();
  Clock::time_point frame_start = connected;
  bool spoke = false;
  uint8_t buffer[16384];
  auto run = [&]() -> void {
    while (true) {
      int timeout = -1;
      if (decoder.mid_frame()) {
        timeout = remaining_ms(frame_start + options.frame_timeout);
      } else if (!spoke) {
        timeout = remaining_ms(connected + options.first_request_timeout);
      }
      pollfd fds[2] = {{c.fd, POLLIN, 0}, {wake[0], POLLIN, 0}};
      const int ready = poll(fds, 2, timeout);
      if (ready < 0) {
        if (errno == EINTR) {
          continue;
        }
        return;
      }
      if (fds[1].revents != 0) {
        return;
      }
      if (ready == 0) {
        if (decoder.mid_frame()) {
          send_message(c.fd, error_reply("", "the frame did not arrive whole within " +
                                                 seconds_text(options.frame_timeout) + "; closing"));
        } else {
          send_message(c.fd, error_reply("", "no request within " + seconds_text(options.first_request_timeout) +
                                                 " of connecting; closing"));
        }
        return;
      }
      const ssize_t n = recv(c.fd, buffer, sizeof buffer, MSG_DONTWAIT);
      if (n == 0) {
        return;  // the client closed (a frame it left unfinished is dropped)
      }
      if (n < 0) {
        if (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK) {
          continue;
        }
        return;
      }
      std::size_t offset = 0;
      while (offset < static_cast<std::size_t>(n)) {
        if (!decoder.mid_frame()) {
          frame_start = Clock::now();
        }
        offset += decoder.feed(buffer + offset, static_cast<std::size_t>(n) - offset);
        if (decoder.state() == FrameDecoder::State::kTooLarge) {
          send_message(c.fd, error_reply("", "a frame of " + std::to_string(decoder.announced_length()) +
                                                 " bytes exceeds the maximum of " +
                                                 std::to_string(options.max_frame_bytes) + "; closing"));
          return;
        }
        if (decoder.state() != FrameDecoder::State::kFrame) {
          continue;
        }
        spoke = true;
        wire::ClientMessage request;
        const std::string_view frame = decoder.frame();
        if (!request.ParseFromArray(frame.data(), static_cast<int>(frame.size()))) {
          send_message(c.fd, error_reply("", "a frame of " + std::to_string(frame.size()) +
                                                 " bytes is not a ClientMessage (libs/proto/handshake.proto); closing"));
          return;
        }
        decoder.next();
        if (c.tcp && !options.tcp_token.empty() && !contract::same_token(request.access_token(), options.tcp_token)) {
          send_message(c.fd, error_reply("access_token", request.access_token().empty()
                                                             ? "this doppel needs its access token over TCP (the "
                                                               "file LINK_DIR/token-PORT; docs/security.md); closing"
                                                             : "wrong access token; closing"));
          return;
        }
        if (!send_message(c.fd, sessions.handle(request))) {
          return;
        }
      }
    }
  };
  try {
    run();
  } catch (const std::exception&) {
    // Out of memory while handling a request: this connection ends, the server goes on.
  }
  close(c.fd);
  c.done.store(true);
}

void Server::Impl::reap(bool all) noexcept {
  std::list<Connection> finished;
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (auto it = clients.begin(); it != clients.end();) {
      const auto next = std::next(it);
      if (all || it->done.load()) {
        finished.splice(finished.end(), clients, it);
      }
      it = next;
    }
  }
  for (Connection& c : finished) {
    if (c.thread.joinable()) {
      c.thread.join();
    }
  }
}

void Server::Impl::close_all() noexcept {
  for (int* fd : {&unix_fd, &tcp_fd, &wake[0], &wake[1]}) {
    if (*fd >= 0) {
      close(*fd);
      *fd = -1;
    }
  }
  struct stat st{};
  if (!unix_path.empty() && lstat(unix_path.c_str(), &st) == 0 && st.st_ino == unix_inode) {
    unlink(unix_path.c_str());  // only our own socket, not one a newer doppel put there
  }
}

Server::Server(contract::RobotHost& host, ServerOptions options) : impl_(std::make_unique<Impl>(host, std::move(options))) {
  Impl& s = *impl_;
  if (s.options.max_frame_bytes == 0 || s.options.max_clients < 1) {
    throw std::invalid_argument("handshake: max_frame_bytes and max_clients must be positive");
  }
  try {
    if (pipe2(s.wake, O_CLOEXEC) != 0) {
      throw std::runtime_error("handshake: pipe: " + error_text(errno));
    }
    if (!s.options.unix_path.empty()) {
      s.open_unix();
    }
    if (s.options.tcp_port) {
      s.open_tcp();
    }
    if (s.unix_fd < 0 && s.tcp_fd < 0) {
      throw std::invalid_argument("handshake: neither a Unix socket nor a TCP port to serve");
    }
    s.listener = std::thread([&s] { s.listen_loop(); });
  } catch (...) {
    s.close_all();
    throw;
  }
}

Server::~Server() { stop(); }

void Server::stop() {
  Impl& s = *impl_;
  if (s.stopped) {
    return;
  }
  s.stopped = true;
  [[maybe_unused]] const ssize_t n = write(s.wake[1], "x", 1);
  if (s.listener.joinable()) {
    s.listener.join();
  }
  s.reap(true);
  s.close_all();
}

const std::string& Server::unix_path() const noexcept { return impl_->unix_path; }

uint16_t Server::tcp_port() const noexcept { return impl_->port; }

std::string Server::describe() const {
  std::string out = "session handshake (docs/handshake.md):";
  if (!impl_->unix_path.empty()) {
    out += " unix " + impl_->unix_path;
  }
  if (impl_->tcp_fd >= 0) {
    const bool v6 = impl_->options.tcp_address.find(':') != std::string::npos;
    out += std::string(impl_->unix_path.empty() ? "" : ",") + " tcp " + (v6 ? "[" : "") + impl_->options.tcp_address +
           (v6 ? "]" : "") + ":" + std::to_string(impl_->port);
  }
  return out + "\n";
}

}  // namespace doppel::handshake
