// doppel-bus run as a user runs it, on recordings written with mcap::Writer the way doppel --record
// writes them (libs/proto/recording.proto schemas as FileDescriptorSets), and on bad files.
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

// A DynamixelSDK-style loop on a Protocol 1.0 bus at 1 Mbps behind an FTDI adapter with its
// default 16 ms latency timer: 12 MX-28 with Return Delay Time 250 us. Start-up: PING 1..13 (13
// is missing: two retries), a READ of each model number; then a 50 Hz loop (the driver sleeps
// until its next 20 ms tick, waking up to 1 ms late) of SYNC WRITE (goal positions, 2 B each) +
// BULK READ (present positions, 2 B each), the driver taking 150 us after each reply.
std::pair<recording::RunInfo, std::vector<recording::BusTransaction>> sdk_style_loop(int cycles) {
  using testing::Bytes;
  using testing::p1_instruction;
  using testing::p1_status;
  constexpr int64_t kLatencyNs = 16'000'000;
  recording::RunInfo run;
  run.set_timing_mode("wire");
  auto* info = run.add_buses();
  info->set_robot_name("sdk-loop");
  info->set_link("ttyDXL0");
  info->set_configured_baud_bps(1'000'000);
  info->set_adapter_latency_ms(16);
  info->set_adapter("ftdi");
  info->set_processing_ns(50'000);
  for (uint8_t id = 1; id <= 12; ++id) {
    auto* d = info->add_devices();
    d->set_id(id);
    d->set_model("MX-28");
    d->set_protocol(1);
    d->set_return_delay_us(250);
  }
  testing::TransactionBuilder builder(0, 1, 1'000'000, 50'000);
  // The FTDI timer ticks every 16 ms: a short reply waits for the next tick.
  auto adapter_ns = [&](int64_t written_ns, std::size_t instruction_bytes, int64_t reply_ns) {
    const int64_t end = written_ns + builder.byte_ns(instruction_bytes) + reply_ns;
    return (end / kLatencyNs + 1) * kLatencyNs - end;
  };
  auto add = [&](int64_t t, const Bytes& instruction, std::vector<testing::StatusSpec> statuses, bool chained = false) {
    int64_t reply = 0;
    for (std::size_t i = 0; i < statuses.size(); ++i) reply += 50'000 + 250'000 + builder.byte_ns(statuses[i].bytes.size());
    builder.add(t, instruction, statuses, chained, statuses.empty() ? 0 : adapter_ns(t, instruction.size(), reply), 20'000)
        .set_adapter_latency_ms(16);
  };
  int64_t t = 1'000'000;
  for (uint8_t id = 1; id <= 13; ++id) {
    for (int attempt = 0; attempt < (id == 13 ? 3 : 1); ++attempt) {
      if (id == 13) {
        builder.add(t, p1_instruction(id, 0x01, {}), {}).set_adapter_latency_ms(16);
        t = builder.transactions().back().instruction_end_ns() + 34'000'000;  // the SDK's ping timeout
      } else {
        add(t, p1_instruction(id, 0x01, {}), {{id, p1_status(id, {}), 250}});
        t = builder.last_done_ns() + 150'000;
      }
    }
  }
  for (uint8_t id = 1; id <= 12; ++id) {
    add(t, p1_instruction(id, 0x02, {0, 2}), {{id, p1_status(id, {29, 0}), 250}});
    t = builder.last_done_ns() + 150'000;
  }
  Bytes sync_write{30, 2};
  Bytes bulk_read{0x00};
  std::vector<testing::StatusSpec> positions;
  for (uint8_t id = 1; id <= 12; ++id) {
    sync_write.insert(sync_write.end(), {id, 0x00, 0x08});
    bulk_read.insert(bulk_read.end(), {2, id, 36});
    positions.push_back({id, p1_status(id, {0x00, 0x08}), 250});
  }
  const int64_t loop_start = (t / 20'000'000 + 1) * 20'000'000;
  uint32_t noise = 12345;
  for (int c = 0; c < cycles; ++c) {
    noise = noise * 1103515245u + 12345u;
    const int64_t wake = loop_start + int64_t{c} * 20'000'000 + (noise >> 8) % 1'000'000;
    builder.add(wake, p1_instruction(0xFE, 0x83, sync_write), {}).set_adapter_latency_ms(16);
    add(wake + 30'000, p1_instruction(0xFE, 0x92, bulk_read), positions, true);
  }
  return {run, builder.transactions()};
}

TEST(DoppelBusTest, SdkStyleLoopBehindA16msLatencyTimer) {
  TempDirectory dir;
  const auto [run, transactions] = sdk_style_loop(500);
  std::string file = (dir / "sdk_loop.mcap").string();
  // DOPPEL_BUS_TEST_KEEP=DIR keeps the recording (docs/analyzer.md's example is this file).
  if (const char* keep = std::getenv("DOPPEL_BUS_TEST_KEEP")) file = (fs::path(keep) / "sdk_loop.mcap").string();
  write_recording(file, run, transactions);
  const ToolRun r = run_tool("report " + file + " --json", dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto report = nlohmann::json::parse(r.out).at("reports").at(0);
  const auto& cycle = report.at("cycle");
  EXPECT_EQ(cycle.at("opener_kind"), "P1 SYNC WRITE");
  EXPECT_EQ(cycle.at("startup_transactions"), 12 + 3 + 12);
  EXPECT_EQ(cycle.at("cycles"), 500);
  EXPECT_NEAR(cycle.at("period").at("mean_us").get<double>(), 20'000.0, 20.0);
  EXPECT_EQ(report.at("timeouts").size(), 3u);
  EXPECT_EQ(report.at("retries"), 2);
  // The BULK READ's reply waits for the adapter's tick: on average far more than its wire time.
  for (const auto& kind : report.at("kinds")) {
    if (kind.at("kind") == "P1 BULK READ") {
      EXPECT_GT(kind.at("adapter").at("mean_us").get<double>(), 1000.0);
    }
  }
  // The default scenarios: recorded settings, with driver time, then latency 1 ms, RDT 0, 2 and 4
  // buses, each on top of the previous.
  const auto& what_if = report.at("what_if");
  ASSERT_EQ(what_if.size(), 6u);
  EXPECT_EQ(what_if.at(1).at("scenario"), "driver=recorded");
  EXPECT_EQ(what_if.at(2).at("scenario"), "latency=1");
  EXPECT_EQ(what_if.at(5).at("scenario"), "rdt=0,latency=1,buses=4");
  // 16 ms timer: the reply's last bytes wait for a tick; 1 ms: the wire's 5.4 ms rounded up to one.
  EXPECT_LT(what_if.at(0).at("rate_hz").get<double>(), 70.0);
  EXPECT_NEAR(what_if.at(2).at("rate_hz").get<double>(), 1e6 / 6000.0, 0.5);
  for (std::size_t i = 3; i < 6; ++i) {
    EXPECT_GT(what_if.at(i).at("rate_hz").get<double>(), what_if.at(i - 1).at("rate_hz").get<double>()) << i;
  }

  // More buses do not help while every reply waits for a 16 ms tick: 62.5 Hz.
  const ToolRun buses = run_tool("report " + file + " --json --what-if buses=4", dir);
  ASSERT_EQ(buses.exit_code, 0) << buses.err;
  const auto only_buses = nlohmann::json::parse(buses.out).at("reports").at(0).at("what_if");
  ASSERT_EQ(only_buses.size(), 2u);
  EXPECT_NEAR(only_buses.at(1).at("rate_hz").get<double>(), 62.5, 0.1);
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

  // Channels but no message (the writer was killed before its first chunk was finished).
  const std::string no_messages = (dir / "no_messages.mcap").string();
  {
    mcap::Writer writer(no_messages);
    writer.add_channel(writer.add_schema("doppel.recording.BusTransaction", "protobuf",
                                         descriptor_set(recording::BusTransaction::descriptor())),
                       "/doppel/bus/0/0/transactions", "protobuf");
    writer.close();
  }
  r = run_tool("report " + no_messages, dir);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("hold no message"), std::string::npos) << r.err;

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
