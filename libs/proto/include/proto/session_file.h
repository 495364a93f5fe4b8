#pragma once
// A session file (session.proto: what a doppel run adds around the robots, such as cameras fixed in
// the field) read from protobuf text, with file:line:column positions for errors (see text_file.h).
// Setup code: everything here may throw.

#include <string>
#include <string_view>

#include "proto/session.pb.h"
#include "proto/text_file.h"

namespace doppel::proto {

class SessionFile : public TextFile {
 public:
  // Reads and parses `path`. Throws std::runtime_error("path: cannot read session file: <reason>") or
  // std::runtime_error("path:line:column: <parser message>") for syntax errors and unknown fields.
  static SessionFile load(const std::string& path);
  // Parses `text` as if it were the file `path` (for tests).
  static SessionFile parse(std::string_view text, const std::string& path);

  const Session& session() const noexcept { return static_cast<const Session&>(message()); }

 private:
  SessionFile() = default;
};

}  // namespace doppel::proto
