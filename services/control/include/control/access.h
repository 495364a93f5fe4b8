#pragma once
// Who may use doppel's HTTP API and the handshake's TCP listener (docs/security.md). TCP on
// loopback has no owner, and any web page the user opens can send requests to 127.0.0.1, so:
// - a per-run secret (the access token, 128 random bits from getrandom) that only the user can
//   read, in a 0600 file of the user's private link directory, LINK_DIR/token-PORT;
// - the Host header must name the address doppel serves on (no DNS rebinding), and a request with
//   an Origin must come from the viewer's own origin; a request that changes something must be
//   application/json (which a web page cannot send cross-origin without a preflight doppel never
//   answers).
// The checks are pure functions of the request's headers, so they are tested without a socket.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "contract/access_token.h"

namespace doppel::control {

// The name of the cookie that carries the token for the server on `port` (cookies are shared by
// every port of a host, hence the port in the name).
std::string token_cookie_name(uint16_t port);

// What the HTTP server lets in: the Host values that name it, and the token ("" = --no-token).
struct AccessPolicy {
  std::vector<std::string> hosts;  // "127.0.0.1:7580", "localhost:7580", "[::1]:7580", ... (lower case)
  bool any_ip_host = false;        // serving on 0.0.0.0 / ::: any IP literal (not rebindable) is also accepted
  uint16_t port = 0;
  std::string token;
};
// The policy of a server bound to `address`:`port`.
AccessPolicy access_policy(const std::string& address, uint16_t port, std::string token);

// The parts of a request the checks look at; a header that is absent is "".
struct RequestHeaders {
  std::string method, path;
  std::string host, origin, content_type, authorization, doppel_token, cookie;
  std::string query_token;  // ?token=... of the URL (the link doppel prints)
};

struct AccessVerdict {
  int status = 200;          // 200: let through; 401 or 403 otherwise
  std::string error;         // why not, for {"error": ...}
  bool set_cookie = false;   // the request brought a right ?token=: give the page its cookie
};
// Host first (403), then Origin (403), then, for a method that changes something (not GET, HEAD
// or OPTIONS), the Content-Type (403), then, for /api/ paths, the token (401) from
// Authorization: Bearer, X-Doppel-Token, the cookie or ?token=.
AccessVerdict check_access(const AccessPolicy& policy, const RequestHeaders& request);

}  // namespace doppel::control
