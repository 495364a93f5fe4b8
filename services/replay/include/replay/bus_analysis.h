#pragma once
// The analyzer's report (analyzer/, docs/analyzer.md) of a recording's bus traffic, as the viewer's
// Bus panel reads it from GET /api/analysis: the control cycle with its period over time, the time
// split per transaction kind and the default what-if scenarios. The file is read again through
// analyzer::read_recording (replay::Recording folds transactions into counters and keeps none), so
// it costs what `doppel-bus report` costs: seconds and hundreds of MB for minutes of a fast loop.
// Setup code: allocates and reads files, on an HTTP worker thread.

#include <cstdint>
#include <optional>
#include <string>

namespace doppel::replay {

// Most points of the period-over-time series (longer series are bucketed, see analyzer::JsonOptions).
inline constexpr std::size_t kAnalysisPeriodPoints = 2000;

// {"reports": [...]} as analyzer::format_json writes it, with each report's "period_series" in
// recording time (seconds from `origin_ns`, the replay's time 0). None when the file holds no bus
// transaction. Throws std::runtime_error naming the file when it cannot be read.
std::optional<std::string> bus_analysis_json(const std::string& path, int64_t origin_ns);

}  // namespace doppel::replay
