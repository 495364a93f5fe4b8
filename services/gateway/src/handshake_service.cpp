#include "gateway/handshake_service.h"

#include <ostream>
#include <stdexcept>
#include <string>

namespace doppel::gateway {

handshake::ServerOptions handshake_options(const Options& options, const std::string& token) {
  handshake::ServerOptions out;
  out.unix_path = options.handshake.socket.empty() ? options.buses.link_dir + "/" + handshake::kSocketName
                                                   : options.handshake.socket;
  if (options.handshake.tcp) {
    out.tcp_port = options.handshake.port.value_or(handshake::kDefaultPort);
  }
  out.tcp_address = options.handshake.address;
  out.tcp_token = token;
  return out;
}

std::unique_ptr<handshake::Server> start_handshake(const Options& options, contract::RobotHost& host,
                                                   const std::string& token, std::ostream& notes) {
  if (!options.handshake.enabled) {
    return nullptr;
  }
  handshake::ServerOptions server = handshake_options(options, token);
  try {
    return std::make_unique<handshake::Server>(host, server);
  } catch (const std::runtime_error& e) {
    if (!server.tcp_port || options.handshake.port) {
      throw;  // its message names the socket or the address and port
    }
    server.tcp_port.reset();
    auto unix_only = std::make_unique<handshake::Server>(host, server);  // throws if the socket was the problem
    notes << "doppel: handshake over TCP off: " << e.what() << "; --handshake-port PORT picks another port\n";
    return unix_only;
  }
}

}  // namespace doppel::gateway
