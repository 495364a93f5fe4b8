#pragma once
// Wiring of the session handshake (handshake/, docs/handshake.md) into doppel: the server serves
// whatever contract::RobotHost the gateway hands it, on the endpoints the options name.

#include <iosfwd>
#include <memory>
#include <string>

#include "contract/robot_host.h"
#include "gateway/options.h"
#include "handshake/server.h"

namespace doppel::gateway {

// The server's endpoints from the options: the Unix socket (default LINK_DIR/handshake.sock) and
// TCP (handshake::kDefaultPort unless named, on 127.0.0.1 unless named), TCP clients needing
// `token` (the run's access token; "" = none).
handshake::ServerOptions handshake_options(const Options& options, const std::string& token);

// Starts serving `host` (which must outlive the server); null with --no-handshake. A port or socket
// the user named must work (std::runtime_error naming the option otherwise); when the default TCP
// port is taken doppel serves the Unix socket only and says so on `notes`.
std::unique_ptr<handshake::Server> start_handshake(const Options& options, contract::RobotHost& host,
                                                   const std::string& token, std::ostream& notes);

}  // namespace doppel::gateway
