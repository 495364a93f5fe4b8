// doppel --record against the real executable: a driver's control loop is recorded transaction
// by transaction, byte-exact and in order, with the world state beside it; a killed doppel leaves
// a file whose finished chunks are readable.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "controlled_doppel.h"
#include "doppel_process.h"
#include "mcap/mcap.h"
#include "proto/recording.pb.h"
#include "reference_client.h"

namespace doppel::record {
namespace {

using testing::Bytes;
using testing::DoppelProcess;
using testing::p1_instruction;
using testing::SerialClient;
using Clock = std::chrono::steady_clock;

struct Exchange {
  Bytes sent;
  Bytes received;
};

std::string temp_file(const std::string& name) {
  return (std::filesystem::temp_directory_path() / (name + "_" + std::to_string(getpid()) + ".mcap")).string();
}

// A walking controller's 10 ms cycle on the default robot (RX servos, no BULK READ): one SYNC WRITE
// of 21 goal positions, then each servo's Present Position read on its own. Logs every exchange.
std::vector<Exchange> control_loop(SerialClient& client, double seconds) {
  std::vector<Exchange> log;
  const auto start = Clock::now();
  for (int cycle = 0; std::chrono::duration<double>(Clock::now() - start).count() < seconds; ++cycle) {
    Bytes sync = {30, 2};
    for (uint8_t id = 1; id <= 21; ++id) {
      const int goal = 512 + (cycle % 20) - 10;
      sync.insert(sync.end(), {id, static_cast<uint8_t>(goal & 0xFF), static_cast<uint8_t>(goal >> 8)});
    }
    const Bytes write = p1_instruction(0xFE, 0x83, sync);
    client.send(write);
    log.push_back({write, {}});
    for (uint8_t id = 1; id <= 21; ++id) {
      const Bytes read = p1_instruction(id, 0x02, {36, 2});
      log.push_back({read, client.transact(read, 8)});
    }
    std::this_thread::sleep_until(start + std::chrono::milliseconds(10 * (cycle + 1)));
  }
  return log;
}

std::vector<recording::BusTransaction> transactions(const mcap::Reader& reader) {
  std::vector<recording::BusTransaction> out;
  mcap::ReadOptions options;
  options.topics = {"/doppel/bus/0/0/transactions"};
  reader.for_each_message(
      [&](const mcap::Message& message) {
        recording::BusTransaction t;
        EXPECT_TRUE(t.ParseFromArray(message.data.data(), static_cast<int>(message.data.size())));
        out.push_back(std::move(t));
        return true;
      },
      options);
  return out;
}

std::string str(const Bytes& b) { return std::string(b.begin(), b.end()); }

// Protobuf's JSON form of a bytes field.
std::string base64(const Bytes& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const uint32_t n = (uint32_t{bytes[i]} << 16) | (i + 1 < bytes.size() ? uint32_t{bytes[i + 1]} << 8 : 0) |
                       (i + 2 < bytes.size() ? uint32_t{bytes[i + 2]} : 0);
    out += kAlphabet[(n >> 18) & 63];
    out += kAlphabet[(n >> 12) & 63];
    out += i + 1 < bytes.size() ? kAlphabet[(n >> 6) & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

TEST(Recording, TenSecondsOfAControlLoopAreRecordedByteExactAndInOrder) {
  const std::string file = temp_file("recording");
  std::vector<Exchange> log;
  std::string output;
  double reached_s = 0.0;  // simulation time just before the stop: what the recording must reach
  {
    DoppelProcess doppel({"--record", file, "--viewer", "0"});
    const std::string url = control_url(doppel);
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1'000'000);
    log = control_loop(client, 10.0);
    const auto [code, state] = run_ctl(doppel, url, "state");
    ASSERT_EQ(code, 0) << state;
    reached_s = nlohmann::json::parse(state)["sim_time_s"].get<double>();
    ASSERT_EQ(doppel.stop(SIGTERM), 0);
    output = doppel.output();
  }
  EXPECT_NE(output.find("recording " + file), std::string::npos) << output;
  EXPECT_NE(output.find(" 0 bus events dropped, 0 world states dropped"), std::string::npos) << output;

  const mcap::Reader reader(file);
  EXPECT_TRUE(reader.complete()) << reader.recovery_note();
  const std::vector<recording::BusTransaction> recorded = transactions(reader);
  ASSERT_EQ(recorded.size(), log.size());
  for (std::size_t i = 0; i < log.size(); ++i) {
    const recording::BusTransaction& t = recorded[i];
    ASSERT_EQ(t.sequence(), i);
    ASSERT_EQ(t.instruction(), str(log[i].sent)) << "transaction " << i;
    std::string answered;
    for (const recording::Status& status : t.statuses()) answered += status.bytes();
    ASSERT_EQ(answered, str(log[i].received)) << "transaction " << i;
    if (i > 0) {
      ASSERT_GE(t.first_seen_ns(), recorded[i - 1].first_seen_ns());
    }
    if (!log[i].received.empty()) {
      ASSERT_GT(t.written_ns(), 0) << "transaction " << i;
    }
  }

  // The world beside it and the run's buses described.
  std::size_t world = 0;
  double first_s = -1.0, last_s = -1.0, widest_gap_s = 0.0;
  recording::RunInfo run;
  mcap::ReadOptions options;
  options.topics = {"/doppel/world", "/doppel/run"};
  reader.for_each_message(
      [&](const mcap::Message& message) {
        if (reader.channels().at(message.channel_id).topic == "/doppel/run") {
          EXPECT_TRUE(run.ParseFromArray(message.data.data(), static_cast<int>(message.data.size())));
        } else {
          recording::WorldState state;
          EXPECT_TRUE(state.ParseFromArray(message.data.data(), static_cast<int>(message.data.size())));
          if (first_s < 0.0) first_s = state.sim_time_s();
          EXPECT_GT(state.sim_time_s(), last_s);
          if (last_s >= 0.0) widest_gap_s = std::max(widest_gap_s, state.sim_time_s() - last_s);
          last_s = state.sim_time_s();
          ++world;
        }
        return true;
      },
      options);
  // Every state the simulation published, however late the recorder's thread ran: one per 10 ms of
  // simulated time (kPublishEveryTicks), none missing, from the start to the stop (how much
  // simulation time 10 s of wall time held depends on the machine's load: asked, not assumed).
  EXPECT_LT(first_s, 0.0105);
  EXPECT_GE(last_s, reached_s - 0.0105) << "doppel had reached " << reached_s << " s";
  EXPECT_GT(reached_s, 1.0);
  EXPECT_LT(widest_gap_s, 0.0105);
  EXPECT_EQ(world, static_cast<std::size_t>(std::lround((last_s - first_s) / 0.010)) + 1);
  ASSERT_EQ(run.buses_size(), 1);
  EXPECT_EQ(run.buses(0).devices_size(), 24);
  // HEAD_PITCH, an RX-28 at its factory Return Delay Time (250 x 2 µs, e-Manual): what the analyzer's
  // "rdt=0" remedy starts from.
  EXPECT_EQ(run.buses(0).devices(0).return_delay_us(), 500u);
  EXPECT_EQ(run.timing_mode(), "wire");

  // The same transactions through a reader written from the MCAP specification alone, in Python
  // (tests/mcap/mcap_read.py), decoding them with the schema stored in the file.
  const auto [code, json_text] = testing::run_command(std::string(DOPPEL_PYTHON3) + " " + DOPPEL_MCAP_READ_PY + " " + file +
                                                      " --decode /doppel/bus/0/0/transactions 2>/dev/null");
  ASSERT_EQ(code, 0) << json_text.substr(0, 2000);
  const nlohmann::json decoded = nlohmann::json::parse(json_text)["decoded"]["/doppel/bus/0/0/transactions"];
  ASSERT_EQ(decoded.size(), log.size());
  for (std::size_t i = 0; i < log.size(); ++i) {
    const nlohmann::json& message = decoded[i]["message"];
    ASSERT_EQ(std::stoull(message.value("sequence", std::string("0"))), i);  // uint64 is a string in JSON
    ASSERT_EQ(message["instruction"].get<std::string>(), base64(log[i].sent)) << "transaction " << i;
  }
  std::filesystem::remove(file);
}

// Faults in a recording (docs/faults.md): /doppel/faults lists each fault with its start and end
// in simulation time, active while it acts, and the bus transactions show what it did: a late
// answer starts exactly its delay later than a punctual one (wire model), a corrupted status has
// a broken checksum.
TEST(Recording, FaultsAreRecordedWithTheirStartEndAndWhatTheyDidOnTheBus) {
  const std::string file = temp_file("recording_faults");
  {
    testing::ControlledDoppel doppel({"--record", file}, false);
    SerialClient client(doppel.doppel.link(), 1'000'000);
    doppel.ok("fault add late 0 --bus 0 --id 18 --value 3000");
    for (uint8_t id : {17, 18}) EXPECT_EQ(client.transact(p1_instruction(id, 0x01), 6, 2000).size(), 6u);
    doppel.ok("fault add corrupt 0 --bus 0 --rate 1 --for 600");
    EXPECT_EQ(client.transact(p1_instruction(1, 0x01), 6, 2000).size(), 6u);
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the recorder samples the list every 2 ms
    doppel.ok("fault clear all");
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
    ASSERT_EQ(doppel.doppel.stop(SIGTERM), 0);
  }
  const mcap::Reader reader(file);
  EXPECT_TRUE(reader.complete()) << reader.recovery_note();
  std::vector<recording::FaultList> lists;
  mcap::ReadOptions options;
  options.topics = {"/doppel/faults"};
  reader.for_each_message(
      [&](const mcap::Message& message) {
        recording::FaultList list;
        EXPECT_TRUE(list.ParseFromArray(message.data.data(), static_cast<int>(message.data.size())));
        lists.push_back(list);
        return true;
      },
      options);
  // The recorder writes the list when it sees it changed (it looks every 2 ms): a recorder kept off
  // the CPU on a loaded machine may see the two adds as one change, so the lists in between are
  // not counted; the first shows the late fault acting, the last every fault's start and end.
  ASSERT_GE(lists.size(), 2u) << "added, cleared";
  ASSERT_GE(lists.front().faults_size(), 1);
  EXPECT_EQ(lists.front().faults(0).kind(), "late");
  EXPECT_TRUE(lists.front().faults(0).active());
  EXPECT_TRUE(lists.front().faults(0).until_cleared());
  for (std::size_t i = 1; i < lists.size(); ++i) EXPECT_GE(lists[i].faults_size(), lists[i - 1].faults_size()) << "list " << i;
  const recording::FaultList& last = lists.back();
  ASSERT_EQ(last.faults_size(), 2);
  EXPECT_EQ(last.faults(0).kind(), "late");
  EXPECT_EQ(last.faults(0).id(), 18);
  EXPECT_EQ(last.faults(0).value_field(), "delay_us");
  EXPECT_EQ(last.faults(0).value(), 3000.0);
  EXPECT_EQ(last.faults(1).kind(), "corrupt");
  EXPECT_EQ(last.faults(1).bus(), 0);
  EXPECT_EQ(last.faults(1).id(), -1);
  EXPECT_EQ(last.faults(1).rate(), 1.0);
  for (const recording::Fault& f : last.faults()) {
    EXPECT_FALSE(f.until_cleared()) << f.kind() << ": cleared, so it has an end";
    EXPECT_FALSE(f.active()) << f.kind();
    EXPECT_GT(f.end_s(), f.start_s()) << f.kind();
  }
  EXPECT_GE(last.faults(1).start_s(), last.faults(0).start_s());

  // The PINGs: 17 punctual, 18 exactly 3 ms later after its instruction, 1 corrupted.
  const std::vector<recording::BusTransaction> recorded = transactions(reader);
  ASSERT_EQ(recorded.size(), 3u);
  for (const recording::BusTransaction& t : recorded) ASSERT_EQ(t.statuses_size(), 1);
  const int64_t punctual = recorded[0].statuses(0).start_ns() - recorded[0].instruction_end_ns();
  const int64_t late = recorded[1].statuses(0).start_ns() - recorded[1].instruction_end_ns();
  EXPECT_EQ(late - punctual, 3'000'000);
  const std::string& corrupted = recorded[2].statuses(0).bytes();
  ASSERT_EQ(corrupted.size(), 6u);
  uint8_t sum = 0;
  for (std::size_t i = 2; i < 5; ++i) sum = static_cast<uint8_t>(sum + static_cast<uint8_t>(corrupted[i]));
  EXPECT_NE(static_cast<uint8_t>(~sum), static_cast<uint8_t>(corrupted[5])) << "the checksum does not match";
  std::filesystem::remove(file);
}

TEST(Recording, AKilledDoppelLeavesItsFinishedChunksReadable) {
  const std::string file = temp_file("recording_killed");
  std::vector<Exchange> log;
  {
    DoppelProcess doppel({"--record", file});
    doppel.wait_for_output("running until");
    SerialClient client(doppel.link(), 1'000'000);
    log = control_loop(client, 3.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // the recorder flushes every second
    doppel.stop(SIGKILL);
  }
  const mcap::Reader reader(file);
  EXPECT_FALSE(reader.complete());
  EXPECT_FALSE(reader.recovery_note().empty());
  const std::vector<recording::BusTransaction> recorded = transactions(reader);
  // Everything before the last flush is there, in order, as the driver sent it.
  EXPECT_GE(recorded.size(), log.size() / 2) << reader.recovery_note();
  ASSERT_LE(recorded.size(), log.size());
  for (std::size_t i = 0; i < recorded.size(); ++i) {
    ASSERT_EQ(recorded[i].sequence(), i);
    ASSERT_EQ(recorded[i].instruction(), str(log[i].sent)) << "transaction " << i;
  }
  std::filesystem::remove(file);
}

TEST(Recording, AFileThatCannotBeWrittenStopsDoppelWithItsName) {
  const auto [code, output] = testing::run_command(testing::doppel_executable() +
                                                   " --no-viewer --no-camera --record /nonexistent-dir/run.mcap 2>&1");
  EXPECT_NE(code, 0);
  EXPECT_NE(output.find("/nonexistent-dir/run.mcap"), std::string::npos) << output;
}

TEST(Recording, RecordCamerasNeedsRecord) {
  const auto [code, output] = testing::run_command(testing::doppel_executable() + " --record-cameras 2 2>&1");
  EXPECT_NE(code, 0);
  EXPECT_NE(output.find("--record-cameras needs --record"), std::string::npos) << output;
}

}  // namespace
}  // namespace doppel::record
