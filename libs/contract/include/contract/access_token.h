#pragma once
// The run's access token (docs/security.md): a per-run secret, 128 random bits from getrandom, that
// only the user can read, in a 0600 file of the user's private link directory, LINK_DIR/token-PORT.
// Whoever asks doppel over TCP brings it: the HTTP API (control/access.h checks its requests) and
// the session handshake's TCP listener alike, so it is part of the contract, not of one transport.

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace doppel::contract {

// 32 lower-case hex digits: 128 bits from getrandom(2). Throws std::runtime_error when the kernel
// gives no randomness (a predictable token would be worse than none).
inline std::string new_access_token() {
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

// Equal without an early exit, so the time taken does not tell how much of a guess was right.
inline bool same_token(std::string_view a, std::string_view b) noexcept {
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

// Where the token of a doppel serving TCP port `port` is: LINK_DIR/token-PORT. Per port, so that a
// doppel and a doppel-replay sharing the default link directory do not overwrite each other's.
inline std::string token_file_path(const std::string& link_dir, uint16_t port) {
  return link_dir + "/token-" + std::to_string(port);
}

// A token as a file, a variable or a header holds it, without the blanks and line end around it.
inline std::string trim_blanks(std::string_view text) {
  const auto first = text.find_first_not_of(" \t");
  if (first == std::string_view::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return std::string(text.substr(first, last - first + 1));
}

// The client's side, one rule for doppel-ctl, doppel-replay --bus, the tests and (in Python)
// programs/examples/handshake/doppel_session.py: $DOPPEL_TOKEN when set, else the first line of
// token_file_path(link_dir, port); nullopt when neither is there (doppel runs with --no-token, or
// in another link directory).
inline std::optional<std::string> find_access_token(const std::string& link_dir, uint16_t port) {
  if (const char* env = std::getenv("DOPPEL_TOKEN"); env != nullptr && *env != '\0') return trim_blanks(env);
  std::ifstream file(token_file_path(link_dir, port));
  std::string line;
  if (!file || !std::getline(file, line)) return std::nullopt;
  line = trim_blanks(line);
  if (line.empty()) return std::nullopt;
  return line;
}

// The token written to `path` with mode 0600 (a temporary file renamed over it, so a reader never
// sees half a token; a symlink at `path` is replaced, not followed), removed again on destruction
// if the file there is still this one. Throws std::runtime_error naming the path.
class TokenFile {
 public:
  TokenFile(std::string path, const std::string& token) : path_(std::move(path)), token_(token) {
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
  ~TokenFile() {
    // Still this file: the same inode (numbers are reused, so) with the same token in it.
    struct stat st{};
    if (::lstat(path_.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || st.st_dev != device_ || st.st_ino != inode_) return;
    std::ifstream file(path_);
    std::string line;
    if (std::getline(file, line) && same_token(line, token_)) ::unlink(path_.c_str());
  }
  TokenFile(const TokenFile&) = delete;
  TokenFile& operator=(const TokenFile&) = delete;
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
  std::string token_;
  uint64_t device_ = 0, inode_ = 0;
};

}  // namespace doppel::contract
