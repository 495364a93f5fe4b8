#pragma once
// The directory that holds the ports' stable links (ttyDXL0, robot1/ttyDXL0). A driver opens
// whatever a link points at, so nobody but the user may be able to add, swap or redirect entries
// there: a directory that is a symbolic link, belongs to another user or is writable by group or
// others is refused (with `allow_shared`, used after a warning). Missing directories are created
// with mode 0700 through file descriptors opened with O_NOFOLLOW, never through a symlink, and the
// ones created here are removed again on destruction when they are empty.

#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace doppel::bus {

// A link directory that is unsafe to use (a symlink, another user's, writable by others).
class UnsafeLinkDirectory : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class LinkDirectory {
 public:
  // Opens `path`, creating it and any missing parents. Throws UnsafeLinkDirectory naming the path
  // and the problem when it is unsafe and `allow_shared` is false (with `allow_shared` a line goes
  // to `warnings` instead), std::runtime_error when a system call fails. Setup only.
  LinkDirectory(std::string path, bool allow_shared, std::ostream& warnings);
  // Removes the directories created here, deepest first, if they are empty.
  ~LinkDirectory();
  LinkDirectory(const LinkDirectory&) = delete;
  LinkDirectory& operator=(const LinkDirectory&) = delete;

  // Opens or creates the subdirectory `name` (one path component, e.g. "robot1") with the same
  // checks; returns its path.
  std::string subdirectory(const std::string& name);

  const std::string& path() const noexcept { return path_; }

 private:
  int open_checked(int parent_fd, const std::string& name, const std::string& shown_path);

  std::string path_;
  bool allow_shared_;
  std::ostream& warnings_;
  int fd_ = -1;                       // O_PATH descriptor of path_
  std::vector<std::string> created_;  // directories made here, in creation order
};

// The default link directory: $XDG_RUNTIME_DIR/doppel when XDG_RUNTIME_DIR names a directory of
// the user's that nobody else can write, otherwise /tmp/doppel-<user name> (the user of the
// effective uid; the uid itself when it has no name).
std::string default_link_dir();

}  // namespace doppel::bus
