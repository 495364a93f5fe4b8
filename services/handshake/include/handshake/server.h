#pragma once
// The session handshake server (docs/handshake.md, libs/proto/handshake.proto): control software connects
// over a Unix socket or TCP, asks contract::RobotHost for robots and gets back their links. One
// listener thread accepts; each client has its own thread (at most max_clients), so a slow robot
// build or a silent client never holds up the others. Host calls are serialized: one robot is
// built or removed at a time.
//
// Bad input never costs more than a bounded buffer and a timeout: an oversized length or bytes that
// do not parse get an Error and the connection is closed; a frame must arrive whole within
// frame_timeout of its first byte, a new connection must send its first request within
// first_request_timeout, and a reply that cannot be written within write_timeout closes the
// connection. A robot outlives its client's connection: remove_robot or doppel's exit removes it.

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "contract/robot_host.h"
#include "handshake/framing.h"
#include "proto/handshake.pb.h"

namespace doppel::handshake {

namespace wire = doppel::proto::handshake;

inline constexpr uint16_t kDefaultPort = 7590;
inline constexpr const char* kSocketName = "handshake.sock";  // in doppel's link directory

struct ServerOptions {
  std::string unix_path;                // "" = no Unix socket
  std::optional<uint16_t> tcp_port;     // nullopt = no TCP; 0 = any free port (tcp_port() tells)
  std::string tcp_address = "127.0.0.1";  // a numeric IPv4 or IPv6 address
  std::string tcp_token;                // the access token every TCP message must carry; "" = none
  uint32_t max_frame_bytes = kDefaultMaxFrameBytes;
  int max_clients = 32;
  std::chrono::milliseconds first_request_timeout{10000};
  std::chrono::milliseconds frame_timeout{5000};
  std::chrono::milliseconds write_timeout{5000};
};

// What the server does with one request, apart from sockets: checks it, asks the host, keeps the
// robots' tokens. Thread-safe (host calls and tokens under one mutex).
class Sessions {
 public:
  explicit Sessions(contract::RobotHost& host) : host_(host) {}
  wire::ServerMessage handle(const wire::ClientMessage& request);

 private:
  wire::ServerMessage add(const wire::AddRobot& request);
  wire::ServerMessage remove(const wire::RemoveRobot& request);
  wire::ServerMessage reattach(const wire::Reattach& request);
  wire::ServerMessage list();

  contract::RobotHost& host_;
  std::mutex mutex_;
  struct Owned {
    uint32_t robot;
    std::string name;
  };
  std::map<std::string, Owned> tokens_;  // token -> the robot it was given for
};

class Server {
 public:
  // Binds and starts listening (throws std::runtime_error naming the socket and why, e.g. another
  // doppel already serves the Unix socket, or the port is taken). A stale socket file nobody
  // listens on is replaced; the socket file is made private to the user (0600).
  Server(contract::RobotHost& host, ServerOptions options);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Closes the listening sockets and every connection, joins the threads, removes the socket file.
  void stop();

  const std::string& unix_path() const noexcept;
  uint16_t tcp_port() const noexcept;  // the bound port; 0 = no TCP
  std::string describe() const;        // one line per endpoint, for doppel's start-up text

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace doppel::handshake
