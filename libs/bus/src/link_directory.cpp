#include "bus/link_directory.h"

#include <fcntl.h>
#include <pwd.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>

namespace doppel::bus {
namespace {

[[noreturn]] void fail(const std::string& what, int error) {
  throw std::runtime_error(what + ": " + std::strerror(error));
}

std::string mode_text(mode_t mode) {
  std::array<char, 8> text{};
  std::snprintf(text.data(), text.size(), "%04o", static_cast<unsigned>(mode & 07777));
  return text.data();
}

// Why directory `st` must not hold the links, or "" when only the user can change it.
std::string unsafe_reason(const struct stat& st) {
  if (st.st_uid != ::geteuid()) {
    return "belongs to uid " + std::to_string(st.st_uid) + ", not to the user (uid " + std::to_string(::geteuid()) +
           ")";
  }
  if ((st.st_mode & (S_IWGRP | S_IWOTH)) != 0) {
    return "is writable by group or others (mode " + mode_text(st.st_mode) + ")";
  }
  return "";
}

// Why the parent of the link directory lets someone else replace it, or "".
std::string unsafe_parent_reason(const struct stat& st) {
  if (st.st_uid != ::geteuid() && st.st_uid != 0) {
    return "its parent directory belongs to uid " + std::to_string(st.st_uid) + ", who can replace it";
  }
  if ((st.st_mode & S_IWOTH) != 0 && (st.st_mode & S_ISVTX) == 0) {
    return "its parent directory is writable by others without the sticky bit (mode " + mode_text(st.st_mode) +
           "), so anyone can replace it";
  }
  return "";
}

std::string symlink_target(int parent_fd, const std::string& name) {
  std::array<char, 4096> target{};
  const ssize_t n = ::readlinkat(parent_fd, name.c_str(), target.data(), target.size() - 1);
  return n > 0 ? std::string(target.data(), static_cast<std::size_t>(n)) : std::string("?");
}

}  // namespace

LinkDirectory::LinkDirectory(std::string path, bool allow_shared, std::ostream& warnings)
    : path_(std::move(path)), allow_shared_(allow_shared), warnings_(warnings) {
  if (path_.empty()) throw std::invalid_argument("link directory: empty path");
  std::vector<std::string> parts;
  std::istringstream split(path_);
  for (std::string part; std::getline(split, part, '/');) {
    if (!part.empty() && part != ".") parts.push_back(part);
  }
  if (parts.empty()) throw std::invalid_argument("link directory '" + path_ + "' names no directory of its own");
  const bool absolute = path_.front() == '/';
  int fd = ::open(absolute ? "/" : ".", O_PATH | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) fail("link directory '" + path_ + "': cannot open " + (absolute ? "/" : "."), errno);
  std::string shown = absolute ? "" : ".";
  try {
    // The user named the existing ancestors (symlinks there, such as /var/run, are theirs to
    // choose); every directory made here is made and opened without following a symlink.
    bool creating = false;
    for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
      shown += "/" + parts[i];
      int next = creating ? -1 : ::openat(fd, parts[i].c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC);
      if (next < 0 && (creating || errno == ENOENT)) {
        if (::mkdirat(fd, parts[i].c_str(), 0700) == 0) {
          created_.push_back(shown);
          creating = true;
        } else if (errno != EEXIST) {
          fail("cannot create directory '" + shown + "' for the port links", errno);
        }
        next = ::openat(fd, parts[i].c_str(), O_PATH | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
      }
      if (next < 0) fail("cannot open directory '" + shown + "' for the port links", errno);
      ::close(fd);
      fd = next;
    }
    struct stat parent {};
    if (::fstat(fd, &parent) != 0) fail("link directory '" + path_ + "': cannot inspect its parent", errno);
    if (const std::string reason = unsafe_parent_reason(parent); !reason.empty()) {
      if (!allow_shared_) throw UnsafeLinkDirectory("link directory '" + path_ + "': " + reason);
      warnings_ << "doppel: warning: link directory '" << path_ << "': " << reason << "; using it anyway\n";
    }
    fd_ = open_checked(fd, parts.back(), path_);
  } catch (...) {
    ::close(fd);
    for (auto it = created_.rbegin(); it != created_.rend(); ++it) ::rmdir(it->c_str());
    throw;
  }
  ::close(fd);
}

LinkDirectory::~LinkDirectory() {
  if (fd_ >= 0) ::close(fd_);
  for (auto it = created_.rbegin(); it != created_.rend(); ++it) {
    ::rmdir(it->c_str());  // fails, as it should, while anything is left inside
  }
}

std::string LinkDirectory::subdirectory(const std::string& name) {
  if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos) {
    throw std::invalid_argument("link directory: '" + name + "' is not a single directory name");
  }
  const std::string path = path_ + "/" + name;
  ::close(open_checked(fd_, name, path));
  return path;
}

int LinkDirectory::open_checked(int parent_fd, const std::string& name, const std::string& shown_path) {
  if (::mkdirat(parent_fd, name.c_str(), 0700) == 0) {
    created_.push_back(shown_path);
  } else if (errno != EEXIST) {
    fail("cannot create link directory '" + shown_path + "'", errno);
  }
  int follow = O_NOFOLLOW;
  struct stat st {};
  if (::fstatat(parent_fd, name.c_str(), &st, AT_SYMLINK_NOFOLLOW) == 0 && S_ISLNK(st.st_mode)) {
    const std::string reason = "is a symbolic link (to '" + symlink_target(parent_fd, name) + "')";
    if (!allow_shared_) {
      throw UnsafeLinkDirectory("link directory '" + shown_path + "' " + reason +
                                "; whoever controls the link decides where the port links go");
    }
    warnings_ << "doppel: warning: link directory '" << shown_path << "' " << reason << "; following it anyway\n";
    follow = 0;
  }
  const int fd = ::openat(parent_fd, name.c_str(), O_PATH | O_DIRECTORY | O_CLOEXEC | follow);
  if (fd < 0) {
    if (errno == ENOTDIR || errno == ELOOP) {
      throw std::runtime_error("link directory '" + shown_path + "' exists and is not a directory");
    }
    fail("cannot open link directory '" + shown_path + "'", errno);
  }
  if (::fstat(fd, &st) != 0 || !S_ISDIR(st.st_mode)) {
    ::close(fd);
    throw std::runtime_error("link directory '" + shown_path + "' exists and is not a directory");
  }
  if (const std::string reason = unsafe_reason(st); !reason.empty()) {
    if (!allow_shared_) {
      ::close(fd);
      throw UnsafeLinkDirectory("link directory '" + shown_path + "' " + reason +
                                "; another user could replace the port links in it");
    }
    warnings_ << "doppel: warning: link directory '" << shown_path << "' " << reason
              << "; using it anyway, other users can replace the port links\n";
  }
  return fd;
}

std::string default_link_dir() {
  if (const char* runtime = std::getenv("XDG_RUNTIME_DIR"); runtime != nullptr && runtime[0] == '/') {
    struct stat st {};
    if (::lstat(runtime, &st) == 0 && S_ISDIR(st.st_mode) && unsafe_reason(st).empty()) {
      return std::string(runtime) + "/doppel";
    }
  }
  passwd entry{};
  passwd* found = nullptr;
  std::array<char, 4096> buffer{};
  if (::getpwuid_r(::geteuid(), &entry, buffer.data(), buffer.size(), &found) == 0 && found != nullptr &&
      found->pw_name != nullptr && found->pw_name[0] != '\0' && std::strchr(found->pw_name, '/') == nullptr) {
    return std::string("/tmp/doppel-") + found->pw_name;
  }
  return "/tmp/doppel-" + std::to_string(::geteuid());
}

}  // namespace doppel::bus
