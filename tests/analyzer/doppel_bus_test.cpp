// doppel-bus run as a user runs it, on recordings written with mcap::Writer the way doppel --record
// writes them (proto/recording.proto schemas as FileDescriptorSets), and on bad files.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include <google/protobuf/descriptor.pb.h>

#include "bitbots_cycle.h"
#include "mcap/mcap.h"

#ifndef DOPPEL_BUS_TOOL
#error "DOPPEL_BUS_TOOL must name the doppel-bus executable"
#endif

namespace doppel::analyzer {
namespace {

namespace fs = std::filesystem;

class TempDirectory {
 public:
  TempDirectory() {
    std::string pattern = (fs::temp_directory_path() / "doppel-bus-test-XXXXXX").string();
    path_ = ::mkdtemp(pattern.data());
  }
  ~TempDirectory() { fs::remove_all(path_); }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

std::string descriptor_set(const google::protobuf::Descriptor* descriptor) {
  google::protobuf::FileDescriptorSet set;
  descriptor->file()->CopyTo(set.add_file());
  return set.SerializeAsString();
}

void write_recording(const std::string& path, const recording::RunInfo& run,
                     const std::vector<recording::BusTransaction>& transactions, uint64_t dropped_messages = 0) {
  mcap::Writer writer(path);
  const uint16_t run_schema = writer.add_schema("doppel.recording.RunInfo", "protobuf", descriptor_set(recording::RunInfo::descriptor()));
  const uint16_t tx_schema =
      writer.add_schema("doppel.recording.BusTransaction", "protobuf", descriptor_set(recording::BusTransaction::descriptor()));
  const uint16_t run_channel = writer.add_channel(run_schema, "/doppel/run", "protobuf");
  std::map<std::pair<uint32_t, uint32_t>, uint16_t> channels;
  const std::string run_bytes = run.SerializeAsString();
  writer.write(run_channel, 0, 1, 1, {reinterpret_cast<const uint8_t*>(run_bytes.data()), run_bytes.size()});
  uint32_t sequence = 0;
  for (const auto& t : transactions) {
    auto& channel = channels[{t.robot(), t.bus()}];
    if (channel == 0) {
      channel = writer.add_channel(tx_schema,
                                   "/doppel/bus/" + std::to_string(t.robot()) + "/" + std::to_string(t.bus()) + "/transactions",
                                   "protobuf");
    }
    const std::string bytes = t.SerializeAsString();
    const auto time = static_cast<uint64_t>(std::max(t.written_ns(), t.seen_ns()));
    writer.write(channel, sequence++, time, time, {reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
  }
  recording::RecordingSummary summary;
  summary.set_messages(transactions.size() + 1);
  summary.set_dropped_messages(dropped_messages);
  const uint16_t summary_channel = writer.add_channel(
      writer.add_schema("doppel.recording.RecordingSummary", "protobuf", descriptor_set(recording::RecordingSummary::descriptor())),
      "/doppel/summary", "protobuf");
  const std::string summary_bytes = summary.SerializeAsString();
  writer.write(summary_channel, sequence, UINT64_MAX / 2, UINT64_MAX / 2,
               {reinterpret_cast<const uint8_t*>(summary_bytes.data()), summary_bytes.size()});
  writer.close();
}

struct ToolRun {
  int exit_code = -1;  // -1: killed by a signal
  std::string out;
  std::string err;
};

ToolRun run_tool(const std::string& arguments, const TempDirectory& dir) {
  const std::string out = (dir / "stdout.txt").string();
  const std::string err = (dir / "stderr.txt").string();
  const std::string command = std::string(DOPPEL_BUS_TOOL) + " " + arguments + " >" + out + " 2>" + err + " </dev/null";
  const int status = std::system(command.c_str());
  ToolRun r;
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  std::stringstream o;
  o << std::ifstream(out).rdbuf();
  r.out = o.str();
  std::stringstream e;
  e << std::ifstream(err).rdbuf();
  r.err = e.str();
  return r;
}

// The Bit-Bots golden numbers (what_if_test.cpp derives them by hand) through a file and the tool.
TEST(DoppelBusTest, ReportsTheBitBotsWhatIfFromARecording) {
  TempDirectory dir;
  const auto b = testing::bitbots(100);
  const std::string file = (dir / "bitbots.mcap").string();
  write_recording(file, b.run, b.transactions, 3);
  const ToolRun r = run_tool("report " + file + " --json --what-if fw=0 --what-if fw=0,buses=4 --what-if fw=50,buses=4", dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto json = nlohmann::json::parse(r.out);
  const auto& report = json.at("reports").at(0);
  EXPECT_EQ(report.at("transactions"), 200);
  EXPECT_EQ(report.at("cycle").at("cycles"), 100);
  const auto& what_if = report.at("what_if");
  ASSERT_EQ(what_if.size(), 4u);  // the recorded settings first
  EXPECT_EQ(what_if.at(1).at("scenario"), "fw=0");
  EXPECT_NEAR(what_if.at(1).at("rate_hz").get<double>(), 704.0, 704.0 * 0.02);
  EXPECT_NEAR(what_if.at(2).at("rate_hz").get<double>(), 2454.0, 2454.0 * 0.02);
  EXPECT_NEAR(what_if.at(3).at("rate_hz").get<double>(), 1521.0, 1521.0 * 0.02);
  EXPECT_NE(r.err.find("read 202 messages"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("the recorder dropped 3 messages"), std::string::npos) << r.err;
}

TEST(DoppelBusTest, TextReportAndPlots) {
  TempDirectory dir;
  const auto b = testing::bitbots(30);
  const std::string file = (dir / "bitbots.mcap").string();
  write_recording(file, b.run, b.transactions);
  const ToolRun r = run_tool("report " + file + " --png " + (dir / "png").string() + " --progress", dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("Control cycle"), std::string::npos);
  EXPECT_NE(r.out.find("P2 SYNC READ"), std::string::npos);
  EXPECT_NE(r.out.find("buses=4"), std::string::npos) << "default scenarios";
  for (const char* name : {"cycle_period.png", "period_histogram.png", "time_split.png", "what_if.png"}) {
    EXPECT_TRUE(fs::exists(dir / "png" / name)) << name;
  }
}

TEST(DoppelBusTest, BadFilesAreNamedWithExitCode2) {
  TempDirectory dir;
  const std::string garbage = (dir / "garbage.mcap").string();
  std::ofstream(garbage) << "this is not an MCAP file at all, just text";
  ToolRun r = run_tool("report " + garbage, dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(garbage), std::string::npos) << r.err;

  const std::string missing = (dir / "missing.mcap").string();
  r = run_tool("report " + missing, dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;

  r = run_tool("report " + (dir / "").string(), dir);
  EXPECT_EQ(r.exit_code, 2);

  // A valid MCAP file without bus transactions.
  const std::string empty = (dir / "empty.mcap").string();
  write_recording(empty, recording::RunInfo(), {});
  r = run_tool("report " + empty, dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("no bus transactions"), std::string::npos) << r.err;

  // A bus that is not in the file.
  const auto b = testing::bitbots(5);
  const std::string file = (dir / "bitbots.mcap").string();
  write_recording(file, b.run, b.transactions);
  r = run_tool("report " + file + " --bus 0/3", dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("0/3"), std::string::npos) << r.err;
}

// Every cut of a recording is read as far as it goes or refused with exit code 2: never a crash.
TEST(DoppelBusTest, CutFilesNeverCrash) {
  TempDirectory dir;
  const auto b = testing::bitbots(200);
  const std::string file = (dir / "bitbots.mcap").string();
  write_recording(file, b.run, b.transactions);
  std::stringstream whole;
  whole << std::ifstream(file, std::ios::binary).rdbuf();
  const std::string bytes = whole.str();
  for (const std::size_t keep : {std::size_t{8}, std::size_t{40}, bytes.size() / 3, bytes.size() / 2, bytes.size() - 30}) {
    const std::string cut = (dir / "cut.mcap").string();
    std::ofstream(cut, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(keep));
    const ToolRun r = run_tool("report " + cut, dir);
    EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 2) << keep << " bytes: exit " << r.exit_code << " " << r.err;
    if (r.exit_code == 2) {
      EXPECT_NE(r.err.find(cut), std::string::npos) << r.err;
    }
  }
}

TEST(DoppelBusTest, BadOptionsAreUsageErrors) {
  TempDirectory dir;
  EXPECT_EQ(run_tool("report x.mcap --what-if speed=fast", dir).exit_code, 1);
  EXPECT_EQ(run_tool("report x.mcap --bus three", dir).exit_code, 1);
  EXPECT_EQ(run_tool("", dir).exit_code, 1);
  EXPECT_EQ(run_tool("--help", dir).exit_code, 0);
}

}  // namespace
}  // namespace doppel::analyzer
