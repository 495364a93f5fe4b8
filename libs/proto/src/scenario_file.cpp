#include "proto/scenario_file.h"

#include <memory>

namespace doppel::proto {

ScenarioFile ScenarioFile::load(const std::string& path) { return parse(read(path, "scenario file"), path); }

ScenarioFile ScenarioFile::parse(std::string_view text, const std::string& path) {
  ScenarioFile file;
  file.parse_into(std::make_unique<Scenario>(), text, path);
  return file;
}

}  // namespace doppel::proto
