#pragma once
// A scenario file (scenario.proto: robots, a schedule of pushes and ball moves, a controller and
// metrics, for `doppel scenario run`) read from protobuf text, with file:line:column positions for errors (see text_file.h).
// Setup code: everything here may throw.

#include <string>
#include <string_view>

#include "proto/scenario.pb.h"
#include "proto/text_file.h"

namespace doppel::proto {

class ScenarioFile : public TextFile {
 public:
  // Reads and parses `path`. Throws std::runtime_error("path: cannot read scenario file: <reason>") or
  // std::runtime_error("path:line:column: <parser message>") for syntax errors and unknown fields.
  static ScenarioFile load(const std::string& path);
  // Parses `text` as if it were the file `path` (for tests).
  static ScenarioFile parse(std::string_view text, const std::string& path);

  const Scenario& scenario() const noexcept { return static_cast<const Scenario&>(message()); }

 private:
  ScenarioFile() = default;
};

}  // namespace doppel::proto
