#pragma once
// A robot description read from a protobuf text file, remembering where every field stood so that
// a semantic error (unknown model, duplicate ID, a link closing a loop) can name file, line and
// field, as a syntax error does. Setup code: everything here may throw.

#include <google/protobuf/text_format.h>

#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>

#include "proto/robot.pb.h"

namespace doppel::proto {

class RobotFile {
 public:
  // Reads and parses `path`. Throws std::runtime_error("path: cannot read ...") or
  // std::runtime_error("path:line:column: <parser message>") for syntax errors and unknown fields.
  static RobotFile load(const std::string& path);
  // Parses `text` as if it were the file `path` (for tests and embedded robots).
  static RobotFile parse(std::string_view text, const std::string& path);

  const RobotDescription& description() const noexcept { return *description_; }
  const std::string& path() const noexcept { return path_; }

  // "path:line:column" of field `field` in `message` (which must be description() or one of its
  // sub-messages); `index` selects an element of a repeated field, -1 otherwise. Falls back to the
  // enclosing message's position, or to "path" alone, when the field was not written in the file.
  std::string location(const google::protobuf::Message& message, std::string_view field, int index = -1) const;

  // Throws std::invalid_argument("<location>: <message type>.<field>: <what>").
  [[noreturn]] void fail(const google::protobuf::Message& message, std::string_view field, int index,
                         std::string_view what) const;

 private:
  RobotFile() = default;
  void index_locations(const google::protobuf::Message& message,
                       const google::protobuf::TextFormat::ParseInfoTree* tree, std::string position);

  std::string path_;
  std::unique_ptr<RobotDescription> description_;
  std::unique_ptr<google::protobuf::TextFormat::ParseInfoTree> tree_;
  struct Node {
    const google::protobuf::TextFormat::ParseInfoTree* tree;  // locations of this message's fields
    std::string position;                                      // "line:column" where the message starts
  };
  std::unordered_map<const google::protobuf::Message*, Node> nodes_;
};

}  // namespace doppel::proto
