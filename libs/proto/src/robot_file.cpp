#include "proto/robot_file.h"

#include <memory>

namespace doppel::proto {

RobotFile RobotFile::load(const std::string& path) { return parse(read(path, "robot description file"), path); }

RobotFile RobotFile::parse(std::string_view text, const std::string& path) {
  RobotFile file;
  file.parse_into(std::make_unique<RobotDescription>(), text, path);
  return file;
}

}  // namespace doppel::proto
