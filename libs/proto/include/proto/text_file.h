#pragma once
// A protobuf text file (robot description, session) that remembers where every field stood, so that
// a semantic error found after parsing (unknown model, duplicate name, value out of range) can name
// file, line and field, as a syntax error does. RobotFile and SessionFile are its typed faces.
// Setup code: everything here may throw.

#include <google/protobuf/message.h>
#include <google/protobuf/text_format.h>

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>
#include <unordered_map>

namespace doppel::proto {

class TextFile {
 public:
  // Limits far above any real file, so that a careless or hostile path (/dev/zero, a huge file, a
  // 50 MB name) cannot exhaust memory or flood the terminal: the file's size, a `description`
  // string, and every other string (names, models, formats).
  static constexpr std::size_t kMaxBytes = 16 * 1024 * 1024;
  static constexpr std::size_t kMaxDescriptionChars = 1024;
  static constexpr std::size_t kMaxNameChars = 64;
  static constexpr std::size_t kMaxPathChars = 1024;  // fields named `file`, `package_path`, `argv`, `value`

  const std::string& path() const noexcept { return path_; }
  // The parsed message (the type given to parse_into()).
  const google::protobuf::Message& message() const noexcept { return *message_; }
  google::protobuf::Message& mutable_message() noexcept { return *message_; }

  // "path:line:column" of field `field` in `message` (which must be message() or one of its
  // sub-messages); `index` selects an element of a repeated field, -1 otherwise. Falls back to the
  // enclosing message's position, or to "path" alone, when the field was not written in the file.
  std::string location(const google::protobuf::Message& message, std::string_view field, int index = -1) const;

  // Makes `generated` (a message added after parsing, e.g. a Link made from a URDF joint) report the
  // location of `source` (a message of the file, e.g. the joint's map entry): its fields by name
  // where `source` has a field of that name, else where `source` starts. Keeps the pointer.
  void alias(const google::protobuf::Message& generated, const google::protobuf::Message& source);

  // Throws std::invalid_argument("<location>: <message type>.<field>: <what>").
  [[noreturn]] void fail(const google::protobuf::Message& message, std::string_view field, int index,
                         std::string_view what) const;

 protected:
  TextFile() = default;
  // The text of `path`; throws std::runtime_error("path: cannot read <what>: <reason>") when it
  // cannot be opened (strerror), is a directory or not a regular file, or exceeds kMaxBytes.
  static std::string read(const std::string& path, std::string_view what);
  // Parses `text` into `message` as the file `path` and keeps both. Throws
  // std::runtime_error("path:line:column: <parser message>") for syntax errors and unknown fields,
  // std::invalid_argument("path:line:column: ...") for a string longer than its limit.
  void parse_into(std::unique_ptr<google::protobuf::Message> message, std::string_view text, const std::string& path);

 private:
  void index_locations(const google::protobuf::Message& message,
                       const google::protobuf::TextFormat::ParseInfoTree* tree, std::string position);
  void check_string_lengths(const google::protobuf::Message& message) const;

  std::string path_;
  std::unique_ptr<google::protobuf::Message> message_;
  std::unique_ptr<google::protobuf::TextFormat::ParseInfoTree> tree_;
  struct Node {
    const google::protobuf::TextFormat::ParseInfoTree* tree;  // locations of this message's fields
    std::string position;                                      // "line:column" where the message starts
    const google::protobuf::Message* source;                   // alias(): the message it stands for
  };
  std::unordered_map<const google::protobuf::Message*, Node> nodes_;
};

}  // namespace doppel::proto
