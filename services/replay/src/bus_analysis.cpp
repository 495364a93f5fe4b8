#include "replay/bus_analysis.h"

#include "analyzer/recording_reader.h"
#include "analyzer/report.h"

namespace doppel::replay {

std::optional<std::string> bus_analysis_json(const std::string& path, int64_t origin_ns) {
  const analyzer::Recording recording = analyzer::read_recording(path, std::nullopt, {}, false);
  if (recording.transactions.empty()) return std::nullopt;
  const std::vector<analyzer::Report> reports = analyzer::make_reports(recording.run, recording.transactions, path);
  analyzer::JsonOptions options;
  options.period_points = kAnalysisPeriodPoints;
  options.origin_ns = origin_ns;
  return analyzer::format_json(reports, options);
}

}  // namespace doppel::replay
