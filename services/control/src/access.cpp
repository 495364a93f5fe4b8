#include "control/access.h"

#include <arpa/inet.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>

namespace doppel::control {
namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool is_ip_literal(const std::string& host) {
  in_addr v4{};
  in6_addr v6{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return true;
  return host.size() > 2 && host.front() == '[' && host.back() == ']' &&
         inet_pton(AF_INET6, host.substr(1, host.size() - 2).c_str(), &v6) == 1;
}

// "host:port" split at the last colon outside brackets; port "" when there is none.
std::pair<std::string, std::string> split_host(const std::string& value) {
  const auto colon = value.rfind(':');
  const auto bracket = value.rfind(']');
  if (colon == std::string::npos || (bracket != std::string::npos && colon < bracket)) return {value, ""};
  return {value.substr(0, colon), value.substr(colon + 1)};
}

bool host_allowed(const AccessPolicy& policy, const std::string& host_header) {
  const std::string host = lower(contract::trim_blanks(host_header));
  if (host.empty()) return false;
  if (std::find(policy.hosts.begin(), policy.hosts.end(), host) != policy.hosts.end()) return true;
  const auto [name, port] = split_host(host);
  const bool port_ok = port == std::to_string(policy.port) || (port.empty() && policy.port == 80);
  if (port_ok && port.empty() && std::find(policy.hosts.begin(), policy.hosts.end(), name + ":80") != policy.hosts.end()) return true;
  return policy.any_ip_host && port_ok && is_ip_literal(name);
}

std::string cookie_value(const std::string& cookies, const std::string& name) {
  std::string_view rest = cookies;
  while (!rest.empty()) {
    const auto end = rest.find(';');
    const std::string pair = contract::trim_blanks(rest.substr(0, end));
    rest = end == std::string_view::npos ? std::string_view() : rest.substr(end + 1);
    const auto equals = pair.find('=');
    if (equals != std::string::npos && pair.substr(0, equals) == name) return pair.substr(equals + 1);
  }
  return "";
}

}  // namespace

std::string token_cookie_name(uint16_t port) { return "doppel_token_" + std::to_string(port); }

AccessPolicy access_policy(const std::string& address, uint16_t port, std::string token) {
  AccessPolicy policy;
  policy.port = port;
  policy.token = std::move(token);
  const std::string p = ":" + std::to_string(port);
  for (const char* local : {"127.0.0.1", "localhost", "[::1]"}) policy.hosts.push_back(local + p);
  const std::string name = lower(address);
  if (name == "0.0.0.0" || name == "::" || name == "[::]") {
    policy.any_ip_host = true;
    char hostname[256] = {};
    if (::gethostname(hostname, sizeof hostname - 1) == 0 && hostname[0] != '\0') policy.hosts.push_back(lower(hostname) + p);
  } else if (name.find(':') != std::string::npos && name.front() != '[') {
    policy.hosts.push_back("[" + name + "]" + p);
  } else {
    policy.hosts.push_back(name + p);
  }
  return policy;
}

AccessVerdict check_access(const AccessPolicy& policy, const RequestHeaders& request) {
  if (!host_allowed(policy, request.host)) {
    return {403, "refused: the Host header '" + request.host.substr(0, 100) +
                     "' does not name this server (a page of another site, or DNS rebinding); use http://" +
                     policy.hosts.front() + "/",
            false};
  }
  if (!request.origin.empty()) {
    const std::string origin = lower(contract::trim_blanks(request.origin));
    const bool own = origin.rfind("http://", 0) == 0 && host_allowed(policy, origin.substr(7));
    if (!own) return {403, "refused: a request from the web page of another origin (" + request.origin.substr(0, 100) + ")", false};
  }
  const bool reads = request.method == "GET" || request.method == "HEAD" || request.method == "OPTIONS";
  if (!reads) {
    const std::string type = lower(contract::trim_blanks(request.content_type.substr(0, request.content_type.find(';'))));
    if (type != "application/json") {
      return {403, "refused: a " + request.method + " request must have Content-Type: application/json", false};
    }
  }
  const bool api = request.path.rfind("/api/", 0) == 0 || request.path == "/api";
  if (policy.token.empty()) return {};
  // ?token= (the link doppel prints) first: it replaces the cookie of an earlier run on this port.
  std::string offered = request.query_token;
  const std::string authorization = contract::trim_blanks(request.authorization);
  if (offered.empty() && lower(authorization.substr(0, 7)) == "bearer ") offered = contract::trim_blanks(authorization.substr(7));
  if (offered.empty()) offered = contract::trim_blanks(request.doppel_token);
  if (offered.empty()) offered = cookie_value(request.cookie, token_cookie_name(policy.port));
  const bool right = contract::same_token(offered, policy.token);
  if (api && !right) {
    return {401, offered.empty() ? "this doppel needs its access token: open the viewer with the link doppel printed "
                                   "(http://HOST:PORT/?token=...), or send the token of LINK_DIR/token-PORT as "
                                   "'Authorization: Bearer TOKEN' (doppel-ctl does; docs/security.md)"
                                 : "wrong access token (doppel makes a new one at every start; docs/security.md)",
            false};
  }
  return {200, "", right && !request.query_token.empty()};
}

}  // namespace doppel::control
