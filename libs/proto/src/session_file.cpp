#include "proto/session_file.h"

#include <memory>

namespace doppel::proto {

SessionFile SessionFile::load(const std::string& path) { return parse(read(path, "session file"), path); }

SessionFile SessionFile::parse(std::string_view text, const std::string& path) {
  SessionFile file;
  file.parse_into(std::make_unique<Session>(), text, path);
  return file;
}

}  // namespace doppel::proto
