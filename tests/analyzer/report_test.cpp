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
