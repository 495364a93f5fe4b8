// What the Writer writes, read by an independent reader written from the spec in Python
// (mcap_read.py: its own record parser, CRC checks, zstd / lz4-frame decompression), and the
// protobuf decoding the recording tests use. Also the corpus of hand-built files the fuzz target
// starts from (fuzz/make_mcap_corpus.py, another writer than ours) read by the C++ Reader.
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "mcap/mcap.h"
#include "mcap_test_support.h"

namespace doppel::mcap {
namespace {

using test::Written;

// Runs mcap_read.py with `args`; its exit status and standard output.
std::pair<int, std::string> run_python(const std::string& args) {
  const std::string command = std::string(DOPPEL_PYTHON3) + " " + DOPPEL_MCAP_READ_PY + " " + args;
  FILE* pipe = ::popen(command.c_str(), "r");
  std::string out;
  char buffer[4096];
  std::size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) out.append(buffer, n);
  const int status = ::pclose(pipe);
  return {status, out};
}

std::string hex(const std::vector<uint8_t>& data) {
  static const char* digits = "0123456789abcdef";
  std::string s;
  for (uint8_t b : data) {
    s.push_back(digits[b >> 4]);
    s.push_back(digits[b & 15]);
  }
  return s;
}

class PythonReader : public ::testing::TestWithParam<Compression> {};

TEST_P(PythonReader, ReadsWhatTheWriterWrote) {
  test::ScratchDir dir;
  const std::string path = dir.file("python.mcap");
  std::vector<Written> written;
  {
    WriterOptions options;
    options.compression = GetParam();
    options.chunk_size = 3000;
    options.profile = "doppel";
    Writer sut(path, options);
    const uint16_t s = sut.add_schema("doppel.test.A", "protobuf", "descriptor");
    const uint16_t topics[3] = {sut.add_channel(s, "/a", "protobuf"), sut.add_channel(s, "/b", "protobuf"),
                                sut.add_channel(0, "/c", "json", {{"unit", "m"}})};
    std::mt19937 rng(5);
    for (uint32_t i = 0; i < 1200; ++i) {
      Written w;
      w.channel_id = topics[rng() % 3];
      w.sequence = i;
      w.log_time_ns = 1'700'000'000'000'000'000 + uint64_t{i} * 1'000'000 - (w.channel_id == 2 ? 7'000'000 : 0);
      w.publish_time_ns = w.log_time_ns + 17;
      w.data.resize(rng() % 200);
      for (auto& b : w.data) b = static_cast<uint8_t>(rng());
      w.order = i;
      sut.write(w.channel_id, w.sequence, w.log_time_ns, w.publish_time_ns, w.data);
      written.push_back(std::move(w));
    }
    sut.add_metadata("session", {{"seed", "5"}});
  }
  const auto [status, out] = run_python(path + " --payloads");
  ASSERT_EQ(status, 0) << out;
  const nlohmann::json py = nlohmann::json::parse(out);
  EXPECT_TRUE(py["complete"].get<bool>());
  EXPECT_EQ(py["profile"], "doppel");
  EXPECT_EQ(py["library"], "doppel");
  EXPECT_EQ(py["message_count"], 1200);
  EXPECT_GT(py["chunk_count"].get<int>(), 10);
  EXPECT_EQ(py["chunk_index_count"], py["chunk_count"]);
  EXPECT_EQ(py["statistics"]["message_count"], 1200);
  EXPECT_EQ(py["statistics"]["chunk_count"], py["chunk_count"]);
  EXPECT_EQ(py["metadata"][0]["name"], "session");
  EXPECT_EQ(py["metadata"][0]["metadata"]["seed"], "5");

  const std::vector<Written> ordered = test::in_log_time_order(written);
  const char* names[3] = {"/a", "/b", "/c"};
  for (uint16_t id = 1; id <= 3; ++id) {
    const nlohmann::json& ch = py["channels"][std::to_string(id)];
    EXPECT_EQ(ch["topic"], names[id - 1]);
    EXPECT_EQ(ch["schema"], id == 3 ? "" : "doppel.test.A");
    std::vector<Written> mine;
    for (const Written& w : ordered)
      if (w.channel_id == id) mine.push_back(w);
    ASSERT_EQ(ch["count"].get<std::size_t>(), mine.size());
    EXPECT_EQ(ch["first_log_time"].get<uint64_t>(), mine.front().log_time_ns);
    EXPECT_EQ(ch["last_log_time"].get<uint64_t>(), mine.back().log_time_ns);
    for (std::size_t i = 0; i < mine.size(); ++i) {
      const nlohmann::json& m = ch["messages"][i];
      ASSERT_EQ(m[0].get<uint64_t>(), mine[i].log_time_ns);
      ASSERT_EQ(m[1].get<uint32_t>(), mine[i].sequence);
      ASSERT_EQ(m[2].get<uint64_t>(), mine[i].publish_time_ns);
      ASSERT_EQ(m[3].get<std::string>(), hex(mine[i].data)) << "channel " << id << " message " << i;
    }
  }
  EXPECT_EQ(py["channels"]["3"]["metadata"]["unit"], "m");
}

INSTANTIATE_TEST_SUITE_P(Compressions, PythonReader,
                         ::testing::Values(Compression::kNone, Compression::kZstd, Compression::kLz4),
                         [](const auto& p) { return test::label(p.param); });

TEST(PythonReaderDecode, DecodesProtobufWithTheSchemasDescriptorSet) {
  test::ScratchDir dir;
  const std::string path = dir.file("proto.mcap");
  {
    google::protobuf::FileDescriptorSet set;
    // descriptor.proto's own FileDescriptorProto: a message without a special JSON form.
    google::protobuf::FileDescriptorProto::descriptor()->file()->CopyTo(set.add_file());
    Writer sut(path);
    const uint16_t s = sut.add_schema("google.protobuf.FileDescriptorProto", "protobuf", set.SerializeAsString());
    const uint16_t c = sut.add_channel(s, "/stamp", "protobuf");
    for (int i = 0; i < 3; ++i) {
      google::protobuf::FileDescriptorProto t;
      t.set_name("file" + std::to_string(i) + ".proto");
      t.add_public_dependency(7 * i);
      const std::string bytes = t.SerializeAsString();
      sut.write(c, static_cast<uint32_t>(i), 1000 + static_cast<uint64_t>(i), 1000,
                {reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
    }
  }
  const auto [status, out] = run_python(path + " --decode /stamp");
  ASSERT_EQ(status, 0) << out;
  const nlohmann::json all = nlohmann::json::parse(out);
  ASSERT_TRUE(all.contains("decoded")) << out;
  const nlohmann::json& decoded = all["decoded"]["/stamp"];
  ASSERT_EQ(decoded.size(), 3u);
  EXPECT_EQ(decoded[0]["log_time"], 1000);
  EXPECT_EQ(decoded[2]["message"]["name"], "file2.proto");
  EXPECT_EQ(decoded[2]["message"]["publicDependency"][0], 14);  // JSON names are lowerCamelCase
}

TEST(PythonReaderDecode, RefusesABadFile) {
  test::ScratchDir dir;
  const std::string path = dir.file("bad.mcap");
  test::write_file(path, "not an mcap file");
  EXPECT_NE(run_python(path).first, 0);
}

// The hand-built corpus: every file reads, and its name says how many messages it holds
// (<name>.<messages>.mcap) or that it is refused (<name>.bad.mcap).
TEST(McapCorpus, HandBuiltFilesReadAsTheirNamesSay) {
  std::size_t files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(DOPPEL_MCAP_CORPUS)) {
    const std::string name = entry.path().filename().string();
    const std::string stem = entry.path().stem().string();  // drops .mcap
    const std::string expect = stem.substr(stem.rfind('.') + 1);
    ++files;
    std::string error;
    std::size_t messages = 0;
    try {
      Reader r(entry.path().string());
      r.for_each_message([&](const Message&) {
        ++messages;
        return true;
      });
    } catch (const std::runtime_error& e) {
      error = e.what();
    }
    if (expect == "bad") {
      EXPECT_NE(error, "") << name;
    } else {
      EXPECT_EQ(error, "") << name;
      EXPECT_EQ(std::to_string(messages), expect) << name;
    }
  }
  EXPECT_GE(files, 5u);
}

}  // namespace
}  // namespace doppel::mcap
