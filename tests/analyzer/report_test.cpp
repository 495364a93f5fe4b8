#include "analyzer/report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "transaction_builder.h"

namespace doppel::analyzer {
namespace {

using testing::Bytes;
using testing::p2_instruction;
using testing::p2_status;
using testing::StatusSpec;
using testing::TransactionBuilder;

// A 2 ms loop on one bus: SYNC WRITE + SYNC READ of 3 servos at 1 Mbps, one READ to a missing ID.
Report sample_report() {
  static std::vector<recording::BusTransaction> transactions;
  recording::RunInfo run;
  run.set_timing_mode("wire");
  auto* info = run.add_buses();
  info->set_link("ttyDXL0");
  info->set_robot_name("sample");
  info->set_processing_ns(50'000);
  TransactionBuilder builder(0, 2, 1'000'000, 50'000);
  std::vector<StatusSpec> statuses;
  Bytes write{116, 0, 4, 0};
  Bytes read{132, 0, 4, 0};
  for (uint8_t id = 1; id <= 3; ++id) {
    write.insert(write.end(), {id, 0, 8, 0, 0});
    read.push_back(id);
    statuses.push_back({id, p2_status(id, {0, 8, 0, 0}), 0});
  }
  builder.add(0, p2_instruction(9, 0x02, {132, 0, 4, 0}), {});
  for (int c = 0; c < 30; ++c) {
    builder.add(10'000'000 + c * 2'000'000, p2_instruction(0xFE, 0x83, write), {});
    builder.add(10'000'000 + c * 2'000'000 + 1000, p2_instruction(0xFE, 0x82, read), statuses, true);
  }
  transactions = builder.transactions();
  Report report;
  report.source = "sample.mcap";
  report.analysis = analyze(run, transactions, 0);
  for (const char* s : {"recorded", "buses=3", "baud=4000000"}) {
    report.what_ifs.push_back(what_if(run, transactions, report.analysis, parse_scenario(s)));
  }
  return report;
}

TEST(ReportTest, TextTablesAreAligned) {
  const std::string text = format_text(sample_report());
  EXPECT_NE(text.find("sample.mcap"), std::string::npos);
  EXPECT_NE(text.find("P2 SYNC READ"), std::string::npos);
  EXPECT_NE(text.find("P2 READ: no status from ID 9"), std::string::npos) << text;
  EXPECT_NE(text.find("buses=3"), std::string::npos);
  // Every row of the time-split table ends in its right-aligned "total" column.
  std::istringstream lines(text);
  std::string line;
  std::size_t width = 0;
  bool in_table = false;
  int rows = 0;
  while (std::getline(lines, line)) {
    if (line.rfind("Time split", 0) == 0) {
      in_table = true;
      continue;
    }
    if (!in_table) continue;
    if (line.empty()) break;
    if (width == 0) width = line.size();
    EXPECT_EQ(line.size(), width) << line;
    ++rows;
  }
  EXPECT_EQ(rows, 1 + 3 * 3);  // header, 3 kinds x mean/p50/p99
}

TEST(ReportTest, JsonHoldsTheNumbers) {
  const Report report = sample_report();
  const auto json = nlohmann::json::parse(format_json({report}));
  const auto& r = json.at("reports").at(0);
  EXPECT_EQ(r.at("source"), "sample.mcap");
  EXPECT_EQ(r.at("cycle").at("cycles"), 30);
  EXPECT_NEAR(r.at("cycle").at("period").at("mean_us").get<double>(), 2000.0, 1e-6);
  EXPECT_EQ(r.at("timeouts").size(), 1u);
  EXPECT_EQ(r.at("what_if").size(), 3u);
  EXPECT_EQ(r.at("what_if").at(1).at("scenario"), "buses=3");
  EXPECT_NEAR(r.at("what_if").at(0).at("rate_hz").get<double>(), report.what_ifs[0].rate_hz, 1e-9);
}

class TempDirectory {
 public:
  TempDirectory() {
    std::string pattern = (std::filesystem::temp_directory_path() / "analyzer-test-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~TempDirectory() { std::filesystem::remove_all(path_); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

bool is_png(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  char magic[8] = {};
  in.read(magic, 8);
  return in && std::string(magic, 8) == "\x89PNG\r\n\x1a\n";
}

TEST(ReportTest, JsonForTheViewerHasThePeriodsOverTimeInBuckets) {
  // 30 cycle starts 2 ms apart from 10 ms: 29 periods; at most 10 points: buckets of 3.
  const Report report = sample_report();
  EXPECT_FALSE(nlohmann::json::parse(format_json({report}))["reports"][0].contains("period_series"));
  JsonOptions options;
  options.period_points = 10;
  options.origin_ns = 4'000'000;
  const auto series = nlohmann::json::parse(format_json({report}, options))["reports"][0]["period_series"];
  EXPECT_EQ(series["per_point"], 3);
  ASSERT_EQ(series["t_s"].size(), 10u);
  ASSERT_EQ(series["period_us"].size(), 10u);
  EXPECT_NEAR(series["t_s"][0].get<double>(), 0.008, 1e-12);  // the first period ends at 12 ms, origin 4 ms
  EXPECT_NEAR(series["t_s"][1].get<double>(), 0.014, 1e-12);  // the fourth at 18 ms
  EXPECT_NEAR(series["t_s"][9].get<double>(), 0.062, 1e-12);  // the 28th (alone in its bucket) at 66 ms
  for (const auto& p : series["period_us"]) EXPECT_NEAR(p.get<double>(), 2000.0, 1e-9);
}

TEST(ReportTest, LastSecondsKeepsTheMostRecentTransactions) {
  std::vector<Transaction> transactions;
  for (int64_t t : std::vector<int64_t>{5'000'000'000, 1'000'000'000, 9'000'000'000, 7'999'999'999, 8'000'000'000}) {
    Transaction x;
    x.first_seen_ns = t;
    transactions.push_back(x);
  }
  const std::vector<Transaction> last = last_seconds(transactions, 1.0);
  ASSERT_EQ(last.size(), 2u);  // 9 s and 8 s, in their order; 7.999999999 s is out
  EXPECT_EQ(last[0].first_seen_ns, 9'000'000'000);
  EXPECT_EQ(last[1].first_seen_ns, 8'000'000'000);
  EXPECT_EQ(last_seconds(transactions, 10.0).size(), 5u);
  EXPECT_TRUE(last_seconds({}, 1.0).empty());
}

TEST(ReportTest, MakeReportsGivesOneReportPerRobotWithTheDefaultScenarios) {
  std::vector<Transaction> transactions;
  for (uint32_t robot : {1u, 0u}) {
    for (int c = 0; c < 10; ++c) {
      Transaction x;
      x.robot = robot;
      x.protocol = 2;
      x.sequence = static_cast<uint64_t>(c);
      x.baud_bps = 1'000'000;
      const Bytes ping = p2_instruction(1, 0x01, {});
      x.instruction = std::string(ping.begin(), ping.end());
      x.first_seen_ns = x.seen_ns = c * 10'000'000 + robot;
      transactions.push_back(x);
    }
  }
  const std::vector<Report> reports = make_reports({}, transactions, "two.mcap");
  ASSERT_EQ(reports.size(), 2u);
  EXPECT_EQ(reports[0].analysis.robot, 0u);
  EXPECT_EQ(reports[1].analysis.robot, 1u);
  EXPECT_EQ(reports[0].source, "two.mcap");
  ASSERT_GE(reports[0].what_ifs.size(), 2u);
  EXPECT_EQ(reports[0].what_ifs[0].label, "recorded");
  EXPECT_EQ(reports[0].what_ifs[1].label, "driver=recorded");
  EXPECT_NEAR(reports[1].analysis.cycle.rate_hz, 100.0, 1e-9);
}

TEST(ReportTest, PlotsArePngFilesDrawnByGnuplot) {
  TempDirectory dir;
  const auto files = write_plots(sample_report(), (dir.path() / "plots").string(), "r0_");
  ASSERT_EQ(files.size(), 4u);
  for (const char* name : {"r0_cycle_period.png", "r0_period_histogram.png", "r0_time_split.png", "r0_what_if.png"}) {
    const std::string file = (dir.path() / "plots" / name).string();
    EXPECT_TRUE(is_png(file)) << file;
    EXPECT_GT(std::filesystem::file_size(file), 2000u) << file;
  }
}

TEST(ReportTest, MissingGnuplotIsAClearError) {
  TempDirectory dir;
  const std::string saved = std::getenv("PATH") ? std::getenv("PATH") : "";
  ::setenv("PATH", dir.path().c_str(), 1);
  try {
    write_plots(sample_report(), dir.path().string());
    ADD_FAILURE() << "no error without gnuplot";
  } catch (const PlotError& e) {
    EXPECT_NE(std::string(e.what()).find("gnuplot-nox"), std::string::npos) << e.what();
  }
  ::setenv("PATH", saved.c_str(), 1);
}

}  // namespace
}  // namespace doppel::analyzer
