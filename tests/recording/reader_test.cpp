// recording::Reader on files written here with mcap::Writer (topics and schema names spelled out,
// not taken from topics.h): what each channel carries, which schema matches, the messages of the
// wanted channels in log-time order, and files that are no recording at all.
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "mcap/mcap.h"
#include "proto/recording.pb.h"
#include "recording/reader.h"

namespace doppel::recording {
namespace {

std::string temp_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("doppel-recording-" + std::to_string(::getpid()) + "-" + name)).string();
}

std::string descriptor_set() {
  google::protobuf::FileDescriptorSet set;
  RunInfo::descriptor()->file()->CopyTo(set.add_file());
  return set.SerializeAsString();
}

// Channels as doppel --record names them, plus foreign and broken ones; one message each, log time
// = 10 * (channel id) ns, written in reverse so that the reader must order them.
const std::string& sample_file() {
  static const std::string path = [] {
    const std::string out = temp_path("sample.mcap");
    mcap::Writer writer(out);
    const std::string data = descriptor_set();
    auto schema = [&](const std::string& type) { return writer.add_schema("doppel.recording." + type, "protobuf", data); };
    const uint16_t run = schema("RunInfo"), transaction = schema("BusTransaction"), camera = schema("CameraImage"),
                   summary = schema("RecordingSummary"), event = schema("BusEvent");
    std::vector<uint16_t> channels = {
        writer.add_channel(run, "/doppel/run", "protobuf"),                          // 1
        writer.add_channel(transaction, "/doppel/bus/2/3/transactions", "protobuf"),  // 2
        writer.add_channel(event, "/doppel/bus/2/3/events", "protobuf"),             // 3
        writer.add_channel(camera, "/doppel/camera/robot1-HEAD_CAMERA", "protobuf"),  // 4
        writer.add_channel(run, "/doppel/world", "protobuf"),                        // 5: wrong schema
        writer.add_channel(summary, "/doppel/summary", "json"),                      // 6: wrong encoding
        writer.add_channel(0, "/doppel/bus/0/0/input", "protobuf"),                  // 7: no schema
        writer.add_channel(run, "/doppel/bus/0/0/gossip", "protobuf"),               // 8: unknown stream
        writer.add_channel(run, "/elsewhere/topic", "protobuf"),                     // 9
        writer.add_channel(camera, "/doppel/camera/", "protobuf"),                   // 10: no camera name
    };
    for (auto id = channels.rbegin(); id != channels.rend(); ++id) {
      const std::string bytes = "message of channel " + std::to_string(*id);
      writer.write(*id, 0, 10u * *id, 10u * *id, {reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()});
    }
    writer.close();
    return out;
  }();
  return path;
}

class RemoveSampleFile : public ::testing::Environment {
 public:
  void TearDown() override { std::filesystem::remove(temp_path("sample.mcap")); }
};
const ::testing::Environment* const kRemoveSampleFile = ::testing::AddGlobalTestEnvironment(new RemoveSampleFile);

TEST(RecordingReader, SaysWhatEachChannelCarries) {
  const Reader sut(sample_file());

  const auto& channels = sut.channels();
  ASSERT_EQ(channels.size(), 10u);
  EXPECT_EQ(channels.at(1).content, Content::kRun);
  EXPECT_EQ(channels.at(2).content, Content::kBusTransactions);
  EXPECT_EQ(channels.at(2).robot, 2u);
  EXPECT_EQ(channels.at(2).bus, 3u);
  EXPECT_EQ(channels.at(3).content, Content::kBusEvents);
  EXPECT_EQ(channels.at(4).content, Content::kCamera);
  EXPECT_EQ(channels.at(4).camera, "robot1-HEAD_CAMERA");
  EXPECT_EQ(channels.at(5).content, Content::kWorld);
  EXPECT_EQ(channels.at(6).content, Content::kSummary);
  EXPECT_EQ(channels.at(7).content, Content::kBusInput);
  EXPECT_EQ(channels.at(8).content, Content::kUnknown);
  EXPECT_EQ(channels.at(9).content, Content::kUnknown);
  EXPECT_EQ(channels.at(10).content, Content::kUnknown);
  EXPECT_EQ(channels.at(9).topic, "/elsewhere/topic");
  EXPECT_TRUE(sut.complete());
  EXPECT_EQ(sut.recovery_note(), "");
}

TEST(RecordingReader, ASchemaMatchesOnlyWithTheContentsMessageTypeAndProtobuf) {
  const Reader sut(sample_file());

  const auto& channels = sut.channels();
  for (uint16_t id : {1, 2, 3, 4}) EXPECT_TRUE(channels.at(id).schema_matches()) << channels.at(id).topic;
  EXPECT_EQ(channels.at(5).schema_name, "doppel.recording.RunInfo");
  EXPECT_FALSE(channels.at(5).schema_matches());  // a RunInfo on the world topic
  EXPECT_EQ(channels.at(6).message_encoding, "json");
  EXPECT_FALSE(channels.at(6).schema_matches());
  EXPECT_EQ(channels.at(7).schema_name, "");
  EXPECT_FALSE(channels.at(7).schema_matches());
  EXPECT_FALSE(channels.at(8).schema_matches());  // nothing to match for an unknown topic
}

TEST(RecordingReader, VisitsEveryMessageInLogTimeOrder) {
  const Reader sut(sample_file());
  std::vector<uint16_t> seen;

  sut.for_each([&](const Channel& channel, const mcap::Message& message) {
    EXPECT_EQ(message.log_time_ns, 10u * channel.id);
    EXPECT_EQ(std::string(message.data.begin(), message.data.end()), "message of channel " + std::to_string(channel.id));
    seen.push_back(channel.id);
    return true;
  });

  EXPECT_EQ(seen, (std::vector<uint16_t>{1, 2, 3, 4, 5, 6, 7, 8, 9, 10}));
}

TEST(RecordingReader, VisitsOnlyTheWantedChannelsAndStopsWhenAsked) {
  const Reader sut(sample_file());
  std::vector<uint16_t> seen;
  auto bus = [](const Channel& channel) { return channel.robot == 2 && channel.bus == 3; };

  sut.for_each([&](const Channel& channel, const mcap::Message&) {
    seen.push_back(channel.id);
    return true;
  }, bus);
  std::vector<uint16_t> first;
  sut.for_each([&](const Channel& channel, const mcap::Message&) {
    first.push_back(channel.id);
    return false;
  });
  bool visited = false;
  sut.for_each([&](const Channel&, const mcap::Message&) { return visited = true; },
               [](const Channel& channel) { return channel.content == Content::kScene; });

  EXPECT_EQ(seen, (std::vector<uint16_t>{2, 3}));
  EXPECT_EQ(first, (std::vector<uint16_t>{1}));
  EXPECT_FALSE(visited);  // no channel wanted: nothing read, not everything
}

TEST(RecordingReader, AFileThatIsNoMcapIsRefusedNamingIt) {
  const std::string path = temp_path("garbage.mcap");
  std::ofstream(path) << "this is not an MCAP file, only some text that a user passed by mistake";

  try {
    const Reader sut(path);
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
  EXPECT_THROW(Reader(temp_path("missing.mcap")), std::runtime_error);
}

}  // namespace
}  // namespace doppel::recording
