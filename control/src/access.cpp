#include "control/access.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace doppel::control {
namespace {

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

std::string trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return std::string(text.substr(first, last - first + 1));
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
  const std::string host = lower(trim(host_header));
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
    const std::string pair = trim(rest.substr(0, end));
    rest = end == std::string_view::npos ? std::string_view() : rest.substr(end + 1);
    const auto equals = pair.find('=');
    if (equals != std::string::npos && pair.substr(0, equals) == name) return pair.substr(equals + 1);
  }
  return "";
}

}  // namespace

std::string new_access_token() {
  uint8_t bytes[16];
  std::size_t got = 0;
  while (got < sizeof bytes) {
    const ssize_t n = getrandom(bytes + got, sizeof bytes - got, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) throw std::runtime_error(std::string("no randomness for the access token: getrandom: ") + std::strerror(errno));
    got += static_cast<std::size_t>(n);
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string token;
  for (const uint8_t b : bytes) {
    token.push_back(kHex[b >> 4]);
    token.push_back(kHex[b & 0xF]);
  }
  return token;
}

bool same_token(std::string_view a, std::string_view b) noexcept {
  // The length is no secret (always 32); the loop runs over the longer input either way.
  const std::size_t n = std::max(a.size(), b.size());
  unsigned difference = a.size() == b.size() ? 0U : 1U;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    difference |= static_cast<unsigned>(x ^ y);
  }
  return difference == 0 && !a.empty();
}

std::string token_file_path(const std::string& link_dir, uint16_t port) {
  return link_dir + "/token-" + std::to_string(port);
}

std::optional<std::string> find_access_token(const std::string& link_dir, uint16_t port) {
  if (const char* env = std::getenv("DOPPEL_TOKEN"); env != nullptr && *env != '\0') return trim(env);
  std::ifstream file(token_file_path(link_dir, port));
  std::string line;
  if (!file || !std::getline(file, line)) return std::nullopt;
  line = trim(line);
  if (line.empty()) return std::nullopt;
  return line;
}

TokenFile::TokenFile(std::string path, const std::string& token) : path_(std::move(path)), token_(token) {
  const std::string temporary = path_ + ".new";
  ::unlink(temporary.c_str());
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("access token " + temporary + ": " + std::strerror(errno));
  const std::string text = token + "\n";
  const bool written = ::fchmod(fd, 0600) == 0 && ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  const int write_error = errno;
  struct stat st{};
  ::fstat(fd, &st);
  ::close(fd);
  if (!written || ::rename(temporary.c_str(), path_.c_str()) != 0) {
    const int error = written ? errno : write_error;
    ::unlink(temporary.c_str());
    throw std::runtime_error("access token " + path_ + ": " + std::strerror(error));
  }
  device_ = st.st_dev;
  inode_ = st.st_ino;
}

TokenFile::~TokenFile() {
  // Still this file: the same inode (numbers are reused, so) with the same token in it.
  struct stat st{};
  if (::lstat(path_.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_dev != device_ || st.st_ino != inode_) return;
  std::ifstream file(path_);
  std::string line;
  if (std::getline(file, line) && same_token(line, token_)) ::unlink(path_.c_str());
}

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
    const std::string origin = lower(trim(request.origin));
    const bool own = origin.rfind("http://", 0) == 0 && host_allowed(policy, origin.substr(7));
    if (!own) return {403, "refused: a request from the web page of another origin (" + request.origin.substr(0, 100) + ")", false};
  }
  const bool reads = request.method == "GET" || request.method == "HEAD" || request.method == "OPTIONS";
  if (!reads) {
    const std::string type = lower(trim(request.content_type.substr(0, request.content_type.find(';'))));
    if (type != "application/json") {
      return {403, "refused: a " + request.method + " request must have Content-Type: application/json", false};
    }
  }
  const bool api = request.path.rfind("/api/", 0) == 0 || request.path == "/api";
  if (policy.token.empty()) return {};
  // ?token= (the link doppel prints) first: it replaces the cookie of an earlier run on this port.
  std::string offered = request.query_token;
  const std::string authorization = trim(request.authorization);
  if (offered.empty() && lower(authorization.substr(0, 7)) == "bearer ") offered = trim(authorization.substr(7));
  if (offered.empty()) offered = trim(request.doppel_token);
  if (offered.empty()) offered = cookie_value(request.cookie, token_cookie_name(policy.port));
  const bool right = same_token(offered, policy.token);
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
