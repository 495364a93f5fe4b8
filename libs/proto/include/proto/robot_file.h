#pragma once
// A robot description read from a protobuf text file, remembering where every field stood so that
// a semantic error (unknown model, duplicate ID, a link closing a loop) can name file, line and
// field, as a syntax error does (see text_file.h). Setup code: everything here may throw.

#include <string>
#include <string_view>

#include "proto/robot.pb.h"
#include "proto/text_file.h"

namespace doppel::proto {

class RobotFile : public TextFile {
 public:
  // Reads and parses `path`. Throws std::runtime_error("path: cannot read ...") or
  // std::runtime_error("path:line:column: <parser message>") for syntax errors and unknown fields.
  static RobotFile load(const std::string& path);
  // Parses `text` as if it were the file `path` (for tests and embedded robots).
  static RobotFile parse(std::string_view text, const std::string& path);

  const RobotDescription& description() const noexcept {
    return static_cast<const RobotDescription&>(message());
  }
  // For loaders that complete the description after parsing (urdf/ fills the figure's bodies and
  // links from Figure.urdf): messages may be added, existing ones must stay where they are.
  RobotDescription& mutable_description() noexcept { return static_cast<RobotDescription&>(mutable_message()); }

 private:
  RobotFile() = default;
};

}  // namespace doppel::proto
