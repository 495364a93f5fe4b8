// The bytes on disk against the spec's record tables (https://mcap.dev/spec), built by hand here:
// magic, Header, Message, Chunk and Footer layouts; files another writer may make (messages outside
// chunks, schemas inside chunks, unknown opcodes, no summary); and bad files: every one is read or
// refused with a std::runtime_error naming the file, never a crash or a hang.
#include <gtest/gtest.h>
#include <zlib.h>

#include <random>
#include <stdexcept>

#include "mcap/mcap.h"
#include "mcap_test_support.h"

namespace doppel::mcap {
namespace {

using test::le;
using test::read_all;
using test::record;
using test::str;
using test::Written;

const std::string kMagic("\x89MCAP0\r\n", 8);  // spec "Magic": 0x89, M, C, A, P, 0x30, \r, \n

std::string crc(const std::string& bytes) {
  return le(::crc32(0, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())), 4);
}

TEST(McapFormat, WriterBytesFollowTheSpecTables) {
  test::ScratchDir dir;
  const std::string path = dir.file("golden.mcap");
  const std::vector<uint8_t> payload = {0xDE, 0xAD, 0xBE, 0xEF, 0x00};
  {
    WriterOptions options;
    options.profile = "ros2";
    options.library = "lib-x";
    options.compression = Compression::kNone;
    Writer sut(path, options);
    const uint16_t s = sut.add_schema("pkg.Msg", "protobuf", "DESC");
    const uint16_t c = sut.add_channel(s, "/topic", "protobuf", {{"k", "v"}});
    sut.write(c, 0x01020304, 0x1122334455667788, 0x0102030405060708, payload);
  }
  const std::string file = test::read_file(path);

  // Magic, then Header (op 0x01): uint64 length, profile and library as uint32-prefixed strings.
  const std::string header = record(0x01, str("ros2") + str("lib-x"));
  ASSERT_GE(file.size(), 8 + header.size());
  EXPECT_EQ(file.substr(0, 8), kMagic);
  EXPECT_EQ(file.substr(8, header.size()), header);

  // Schema (0x03) and Channel (0x04) records in the data section before the chunk that uses them.
  const std::string schema = record(0x03, le(1, 2) + str("pkg.Msg") + str("protobuf") + le(4, 4) + "DESC");
  const std::string channel =
      record(0x04, le(1, 2) + le(1, 2) + str("/topic") + str("protobuf") + le(10, 4) + str("k") + str("v"));
  std::size_t at = 8 + header.size();
  EXPECT_EQ(file.substr(at, schema.size()), schema);
  at += schema.size();
  EXPECT_EQ(file.substr(at, channel.size()), channel);
  at += channel.size();

  // Message (0x05): channel_id u16, sequence u32, log_time u64, publish_time u64, data.
  const std::string message =
      record(0x05, le(1, 2) + le(0x01020304, 4) + le(0x1122334455667788, 8) + le(0x0102030405060708, 8) +
                       std::string(payload.begin(), payload.end()));
  // Chunk (0x06): start, end, uncompressed_size, uncompressed_crc, compression "", records (u64-prefixed).
  const std::string chunk = record(0x06, le(0x1122334455667788, 8) + le(0x1122334455667788, 8) +
                                             le(message.size(), 8) + crc(message) + str("") + le(message.size(), 8) +
                                             message);
  EXPECT_EQ(file.substr(at, chunk.size()), chunk);
  at += chunk.size();
  // Message Index (0x07) for channel 1: one (log_time, offset 0) pair.
  const std::string index = record(0x07, le(1, 2) + le(16, 4) + le(0x1122334455667788, 8) + le(0, 8));
  EXPECT_EQ(file.substr(at, index.size()), index);
  at += index.size();
  // Data End (0x0F) with the CRC of every byte before it.
  EXPECT_EQ(file.substr(at, 13), record(0x0F, crc(file.substr(0, at))));
  at += 13;

  // Footer (0x02): summary_start, summary_offset_start, summary_crc; then the magic again.
  ASSERT_GE(file.size(), at + 29 + 8);
  const std::size_t footer = file.size() - 8 - 29;
  EXPECT_EQ(file.substr(file.size() - 8), kMagic);
  EXPECT_EQ(file.substr(footer, 9), std::string(1, '\x02') + le(20, 8));
  EXPECT_EQ(file.substr(footer + 9, 8), le(at, 8));  // the summary starts right after Data End
  EXPECT_EQ(file.substr(at, schema.size()), schema);  // with the schemas (grouped by opcode)
  EXPECT_EQ(file.substr(footer + 25, 4), crc(file.substr(at, footer + 25 - at)));
}

// A file as another writer may make it: messages outside chunks, a schema and channel inside a
// chunk, private and unknown records, no summary, a Data End with CRC 0.
std::string foreign_file() {
  const std::string header = record(0x01, str("") + str("hand"));
  const std::string channel1 = record(0x04, le(1, 2) + le(0, 2) + str("/loose") + str("json") + le(0, 4));
  auto message = [](uint16_t ch, uint32_t seq, uint64_t t, const std::string& data) {
    return record(0x05, le(ch, 2) + le(seq, 4) + le(t, 8) + le(t, 8) + data);
  };
  const std::string inner = record(0x03, le(7, 2) + str("S") + str("jsonschema") + le(2, 4) + "{}") +
                            record(0x04, le(2, 2) + le(7, 2) + str("/chunked") + str("json") + le(0, 4)) +
                            message(2, 1, 150, "c1") + record(0x42, "future record") + message(2, 2, 50, "c0");
  const std::string chunk = record(0x06, le(50, 8) + le(150, 8) + le(inner.size(), 8) + le(0, 4) + str("") +
                                             le(inner.size(), 8) + inner);
  return kMagic + header + channel1 + message(1, 1, 100, "l1") + record(0x80, "private") + chunk +
         message(1, 2, 40, "l0") + record(0x7E, "") + record(0x0F, le(0, 4)) + record(0x02, le(0, 8) + le(0, 8) + le(0, 4)) +
         kMagic;
}

TEST(McapFormat, ReadsMessagesOutsideChunksAndSkipsUnknownRecords) {
  test::ScratchDir dir;
  const std::string path = dir.file("foreign.mcap");
  test::write_file(path, foreign_file());
  Reader sut(path);
  EXPECT_TRUE(sut.complete());
  const std::vector<Written> got = read_all(sut);
  ASSERT_EQ(got.size(), 4u);
  const uint64_t times[] = {40, 50, 100, 150};
  const char* data[] = {"l0", "c0", "l1", "c1"};
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(got[i].log_time_ns, times[i]);
    EXPECT_EQ(std::string(got[i].data.begin(), got[i].data.end()), data[i]);
  }
  EXPECT_EQ(sut.channels().at(2).topic, "/chunked");
  EXPECT_EQ(sut.schemas().at(7).name, "S");
  EXPECT_EQ(sut.statistics().message_count, 4u);
  ReadOptions only_loose;
  only_loose.topics = {"/loose"};
  EXPECT_EQ(read_all(sut, only_loose).size(), 2u);
}

// Reads `path` fully; returns the error message, or "" when it read.
std::string try_read(const std::string& path, std::size_t* messages = nullptr) {
  try {
    Reader r(path);
    const std::size_t n = read_all(r).size();
    if (messages != nullptr) *messages = n;
    (void)r.statistics();
    return "";
  } catch (const std::runtime_error& e) {
    return e.what();
  }
}

std::string written_file(const test::ScratchDir& dir, Compression c, std::vector<Written>* written = nullptr) {
  const std::string path = dir.file("good.mcap");
  WriterOptions options;
  options.compression = c;
  options.chunk_size = 600;
  Writer w(path, options);
  const uint16_t ch = w.add_channel(w.add_schema("S", "protobuf", "x"), "/a", "protobuf");
  for (uint32_t i = 0; i < 40; ++i) {
    const std::vector<uint8_t> data(20 + i % 7, static_cast<uint8_t>(i));
    w.write(ch, i, 1000 + i, 1000 + i, data);
    if (written != nullptr) written->push_back({ch, i, 1000 + i, 1000 + i, data, i});
  }
  w.add_metadata("m", {{"a", "b"}});
  w.close();
  return test::read_file(path);
}

TEST(McapBadInput, TruncationsReadAPrefixOfTheMessages) {
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    test::ScratchDir dir;
    std::vector<Written> written;
    const std::string good = written_file(dir, c, &written);
    const std::string path = dir.file("cut.mcap");
    const std::size_t header_end = 8 + 9 + 8 + 6;  // magic, Header with profile "" and library "doppel"
    for (std::size_t n = 0; n < good.size(); ++n) {
      test::write_file(path, good.substr(0, n));
      if (n < header_end) {
        EXPECT_NE(try_read(path).rfind(path + ": ", 0), std::string::npos) << n;
        continue;
      }
      Reader r(path);
      EXPECT_FALSE(r.complete()) << n;
      EXPECT_NE(r.recovery_note(), "") << n;
      const std::vector<Written> got = read_all(r);
      ASSERT_LE(got.size(), written.size());
      for (std::size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], written[i]) << "cut at " << n;
      EXPECT_EQ(r.statistics().message_count, got.size());
    }
  }
}

TEST(McapBadInput, CorruptedBytesAreReadOrRefusedWithTheFileName) {
  std::mt19937 rng(3);
  for (Compression c : {Compression::kNone, Compression::kZstd, Compression::kLz4}) {
    test::ScratchDir dir;
    const std::string good = written_file(dir, c);
    const std::string path = dir.file("bad.mcap");
    for (int trial = 0; trial < 1500; ++trial) {
      std::string bad = good;
      const int flips = 1 + static_cast<int>(rng() % 3);
      for (int i = 0; i < flips; ++i) {
        const std::size_t at = rng() % bad.size();
        bad[at] = static_cast<char>(trial % 4 == 0 ? 0xFF : rng());
      }
      test::write_file(path, bad);
      const std::string error = try_read(path);
      if (!error.empty()) {
        EXPECT_EQ(error.rfind(path + ": ", 0), 0u) << error;
      }
    }
  }
}

TEST(McapBadInput, NamedProblemsAndOffsets) {
  test::ScratchDir dir;
  const std::string good = written_file(dir, Compression::kZstd);
  const std::string path = dir.file("bad.mcap");
  auto error_of = [&](const std::string& bytes) {
    test::write_file(path, bytes);
    return try_read(path);
  };
  EXPECT_NE(error_of("").find("not an MCAP file"), std::string::npos);
  EXPECT_NE(error_of("PK\x03\x04 not mcap at all").find("not an MCAP file"), std::string::npos);
  std::string wrong = good;
  wrong[1] = 'X';
  EXPECT_NE(error_of(wrong).find("not an MCAP file"), std::string::npos);

  // The Header's length past the end of the file.
  std::string huge = good;
  huge.replace(9, 8, le(~uint64_t{0} - 3, 8));
  EXPECT_NE(error_of(huge).find("Header record runs past the end of the file at byte 8"), std::string::npos)
      << error_of(huge);

  // A chunk's compressed bytes damaged: named as a bad chunk with its offset.
  std::string damaged = good;
  const std::size_t chunk = damaged.find(std::string(1, '\x06'), 8 + 9 + 14);
  const std::size_t zstd_magic = damaged.find("\x28\xB5\x2F\xFD", chunk);
  ASSERT_NE(zstd_magic, std::string::npos);
  for (std::size_t i = zstd_magic + 6; i < zstd_magic + 30; ++i) damaged[i] = static_cast<char>(damaged[i] ^ 0x5A);
  EXPECT_NE(error_of(damaged).find("data section CRC mismatch (Data End record) at byte "), std::string::npos)
      << error_of(damaged);
  // Without the data section CRC (0: "not available") the chunk's own checks find it.
  const std::size_t footer = damaged.size() - 8 - 29;
  uint64_t start = 0;
  for (int i = 7; i >= 0; --i) start = (start << 8) | static_cast<uint8_t>(damaged[footer + 9 + i]);
  ASSERT_EQ(damaged[start - 13], '\x0F');
  damaged.replace(start - 4, 4, le(0, 4));
  const std::string e = error_of(damaged);
  EXPECT_NE(e.find("chunk at byte " + std::to_string(chunk)), std::string::npos) << e;

  // A summary with a bad CRC.
  std::string summary = good;
  summary[summary.size() - 8 - 29 - 3] ^= 1;  // last byte of the last summary offset record
  EXPECT_NE(error_of(summary).find("summary CRC mismatch"), std::string::npos) << error_of(summary);
}

}  // namespace
}  // namespace doppel::mcap
