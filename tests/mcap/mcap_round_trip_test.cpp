// Writer -> Reader round trips: many messages on several channels, out of log-time order across
// channels, many small chunks, each compression; filters; metadata and statistics; write errors.
#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

#include "mcap/mcap.h"
#include "mcap_test_support.h"

namespace doppel::mcap {
namespace {

using test::read_all;
using test::Written;

// Writes `n` messages on three channels of two schemas. Each channel's clock runs with its own
// offset and jitter, so consecutive writes are out of log-time order; some log times repeat.
std::vector<Written> write_sample(Writer& sut, int n, uint32_t seed = 7) {
  const uint16_t imu = sut.add_schema("doppel.test.Imu", "protobuf", std::string("\x0a\x03imu", 5));
  const uint16_t joints = sut.add_schema("doppel.test.Joints", "jsonschema", "{\"type\":\"object\"}");
  const uint16_t ch[3] = {sut.add_channel(imu, "/imu", "protobuf", {{"rate_hz", "1000"}}),
                          sut.add_channel(joints, "/joints", "json"),
                          sut.add_channel(0, "/raw/bus0", "", {{"bus", "0"}})};
  std::mt19937 rng(seed);
  std::vector<Written> written;
  for (int i = 0; i < n; ++i) {
    const int c = static_cast<int>(rng() % 3);
    Written w;
    w.channel_id = ch[c];
    w.sequence = static_cast<uint32_t>(i);
    // 1 ms steps, channel 1 logged 5 ms late, channel 2 0..9 ms early; ties on purpose.
    const int64_t skew_ms = c == 0 ? 0 : (c == 1 ? 5 : -static_cast<int64_t>(rng() % 10));
    w.log_time_ns = static_cast<uint64_t>(1'000'000'000'000 + (i / 2 + skew_ms) * 1'000'000);
    w.publish_time_ns = w.log_time_ns - 1000 * static_cast<uint64_t>(c);
    w.data.resize(rng() % 300);
    for (auto& b : w.data) b = static_cast<uint8_t>(rng());
    w.order = written.size();
    sut.write(w.channel_id, w.sequence, w.log_time_ns, w.publish_time_ns, w.data);
    written.push_back(std::move(w));
  }
  return written;
}

class RoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(RoundTrip, MessagesComeBackInLogTimeOrderWithTheirBytes) {
  test::ScratchDir dir;
  const std::string path = dir.file("round_trip.mcap");
  std::vector<Written> written;
  {
    WriterOptions options;
    options.compression = GetParam();
    options.chunk_size = 4096;
    options.profile = "doppel";
    Writer sut(path, options);
    written = write_sample(sut, 5000);
    sut.add_metadata("session", {{"robot", "darwin-op"}, {"seed", "7"}});
    sut.close();
    EXPECT_EQ(sut.counters().messages, 5000u);
    EXPECT_GT(sut.counters().chunks, 50u);
  }

  Reader reader(path);
  EXPECT_TRUE(reader.complete());
  EXPECT_EQ(reader.recovery_note(), "");
  EXPECT_EQ(reader.profile(), "doppel");
  const std::vector<Written> got = read_all(reader);
  const std::vector<Written> expected = test::in_log_time_order(written);
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], expected[i]) << "message " << i;

  ASSERT_EQ(reader.schemas().size(), 2u);
  EXPECT_EQ(reader.schemas().at(1).name, "doppel.test.Imu");
  EXPECT_EQ(reader.schemas().at(1).data, std::string("\x0a\x03imu", 5));
  EXPECT_EQ(reader.schemas().at(2).encoding, "jsonschema");
  ASSERT_EQ(reader.channels().size(), 3u);
  EXPECT_EQ(reader.channels().at(1).topic, "/imu");
  EXPECT_EQ(reader.channels().at(1).metadata.at("rate_hz"), "1000");
  EXPECT_EQ(reader.channels().at(3).schema_id, 0);
  EXPECT_EQ(reader.channels().at(3).topic, "/raw/bus0");

  const Statistics stats = reader.statistics();
  EXPECT_EQ(stats.message_count, 5000u);
  EXPECT_EQ(stats.message_start_time, expected.front().log_time_ns);
  EXPECT_EQ(stats.message_end_time, expected.back().log_time_ns);
  uint64_t per_channel = 0;
  for (const auto& [id, n] : stats.channel_message_counts) {
    EXPECT_EQ(n, static_cast<uint64_t>(std::count_if(written.begin(), written.end(),
                                                     [id = id](const Written& w) { return w.channel_id == id; })));
    per_channel += n;
  }
  EXPECT_EQ(per_channel, 5000u);
  ASSERT_EQ(reader.metadata().size(), 1u);
  EXPECT_EQ(reader.metadata()[0].first, "session");
  EXPECT_EQ(reader.metadata()[0].second.at("robot"), "darwin-op");
}

TEST_P(RoundTrip, TimeRangeAndTopicFiltersSelectExactly) {
  test::ScratchDir dir;
  const std::string path = dir.file("filters.mcap");
  std::vector<Written> written;
  {
    WriterOptions options;
    options.compression = GetParam();
    options.chunk_size = 2048;
    Writer sut(path, options);
    written = write_sample(sut, 3000, 11);
  }
  Reader reader(path);
  ReadOptions options;
  options.start_ns = 1'000'000'000'000 + 300 * 1'000'000;  // a tie-heavy boundary
  options.end_ns = 1'000'000'000'000 + 900 * 1'000'000;
  options.topics = {"/imu", "/raw/bus0"};
  std::vector<Written> expected;
  for (const Written& w : test::in_log_time_order(written))
    if (w.log_time_ns >= *options.start_ns && w.log_time_ns < *options.end_ns && w.channel_id != 2) expected.push_back(w);
  const std::vector<Written> got = read_all(reader, options);
  ASSERT_FALSE(expected.empty());
  ASSERT_EQ(got.size(), expected.size());
  for (std::size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], expected[i]) << "message " << i;

  options.topics = {"/nothing"};
  EXPECT_TRUE(read_all(reader, options).empty());

  // Stopping early: the visitor's false ends the walk and is returned.
  int seen = 0;
  EXPECT_FALSE(reader.for_each_message([&](const Message&) { return ++seen < 10; }));
  EXPECT_EQ(seen, 10);
}

INSTANTIATE_TEST_SUITE_P(Compressions, RoundTrip,
                         ::testing::Values(Compression::kNone, Compression::kZstd, Compression::kLz4),
                         [](const auto& p) { return test::label(p.param); });

TEST(McapWriter, AnEmptyFileReadsBackEmptyAndComplete) {
  test::ScratchDir dir;
  const std::string path = dir.file("empty.mcap");
  { Writer sut(path); }
  Reader reader(path);
  EXPECT_TRUE(reader.complete());
  EXPECT_EQ(reader.statistics().message_count, 0u);
  EXPECT_TRUE(read_all(reader).empty());
}

TEST(McapWriter, FlushClosesTheChunkEarly) {
  test::ScratchDir dir;
  Writer sut(dir.file("flush.mcap"));
  const uint16_t ch = sut.add_channel(0, "/t", "");
  const uint8_t byte = 1;
  sut.write(ch, 0, 10, 10, {&byte, 1});
  EXPECT_EQ(sut.counters().chunks, 0u);
  sut.flush();
  EXPECT_EQ(sut.counters().chunks, 1u);
  sut.flush();  // nothing open: no empty chunk
  EXPECT_EQ(sut.counters().chunks, 1u);
  EXPECT_EQ(sut.counters().bytes, std::filesystem::file_size(dir.file("flush.mcap")));
}

TEST(McapWriter, RefusesUnknownIdsAndUnwritablePaths) {
  test::ScratchDir dir;
  Writer sut(dir.file("ids.mcap"));
  EXPECT_THROW(sut.add_channel(3, "/t", "protobuf"), std::runtime_error);
  const uint8_t byte = 1;
  EXPECT_THROW(sut.write(1, 0, 0, 0, {&byte, 1}), std::runtime_error);
  EXPECT_THROW(sut.write(0, 0, 0, 0, {&byte, 1}), std::runtime_error);
  try {
    Writer bad(dir.file("no/such/dir/x.mcap"));
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no/such/dir/x.mcap"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace doppel::mcap
