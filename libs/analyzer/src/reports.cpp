#include <algorithm>
#include <set>

#include "analyzer/report.h"

namespace doppel::analyzer {

std::vector<Report> make_reports(const recording::RunInfo& run, std::span<const Transaction> transactions,
                                 const std::string& source, const std::vector<Scenario>& scenarios) {
  std::set<uint32_t> robots;
  for (const Transaction& t : transactions) robots.insert(t.robot);
  std::vector<Report> reports;
  for (uint32_t robot : robots) {
    Report r;
    r.source = source;
    r.analysis = analyze(run, transactions, robot);
    std::vector<Scenario> list;
    if (scenarios.empty()) {
      list = default_scenarios(run, r.analysis);
    } else {
      list.push_back(Scenario{});
      list.insert(list.end(), scenarios.begin(), scenarios.end());
    }
    for (const Scenario& s : list) r.what_ifs.push_back(what_if(run, transactions, r.analysis, s));
    reports.push_back(std::move(r));
  }
  return reports;
}

std::vector<Transaction> last_seconds(std::span<const Transaction> transactions, double seconds) {
  int64_t latest = 0;
  bool any = false;
  for (const Transaction& t : transactions) {
    latest = any ? std::max(latest, t.first_seen_ns) : t.first_seen_ns;
    any = true;
  }
  const int64_t from = latest - static_cast<int64_t>(seconds * 1e9);
  std::vector<Transaction> out;
  for (const Transaction& t : transactions) {
    if (t.first_seen_ns >= from) out.push_back(t);
  }
  return out;
}

}  // namespace doppel::analyzer
