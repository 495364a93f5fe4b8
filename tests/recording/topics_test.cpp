// Topic names as docs/recording.md's table ("What is recorded") writes them, and bus topics taken
// apart: a reader must never mistake another topic for a bus of some robot.
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include <set>
#include <string>

#include "proto/recording.pb.h"
#include "recording/reader.h"
#include "recording/topics.h"

namespace doppel::recording {
namespace {

TEST(RecordingTopics, AreTheOnesTheRecordingDocumentNames) {
  EXPECT_EQ(kRunTopic, "/doppel/run");
  EXPECT_EQ(kWorldTopic, "/doppel/world");
  EXPECT_EQ(kServosTopic, "/doppel/servos");
  EXPECT_EQ(kSceneTopic, "/doppel/scene");
  EXPECT_EQ(kScenePosesTopic, "/doppel/scene_poses");
  EXPECT_EQ(kFaultsTopic, "/doppel/faults");
  EXPECT_EQ(kSummaryTopic, "/doppel/summary");
  EXPECT_EQ(bus_topic(0, 1, BusStream::kTransactions), "/doppel/bus/0/1/transactions");
  EXPECT_EQ(bus_topic(2, 0, BusStream::kInput), "/doppel/bus/2/0/input");
  EXPECT_EQ(bus_topic(5, 12, BusStream::kEvents), "/doppel/bus/5/12/events");
  EXPECT_EQ(camera_topic("robot1-HEAD_CAMERA"), "/doppel/camera/robot1-HEAD_CAMERA");
}

TEST(RecordingTopics, BusTopicsAreTakenApart) {
  const auto sut = parse_bus_topic("/doppel/bus/3/14/transactions");

  ASSERT_TRUE(sut.has_value());
  EXPECT_EQ(sut->robot, 3u);
  EXPECT_EQ(sut->bus, 14u);
  EXPECT_EQ(sut->stream, "transactions");
  const auto other = parse_bus_topic("/doppel/bus/0/0/something_new");
  ASSERT_TRUE(other.has_value());
  EXPECT_EQ(other->stream, "something_new");
}

TEST(RecordingTopics, OtherTopicsAreNoBusTopics) {
  for (const char* topic : {"/doppel/world", "/doppel/bus/", "/doppel/bus/0/1", "/doppel/bus/0/1/", "/doppel/bus//1/events",
                            "/doppel/bus/0//events", "/doppel/bus/a/1/events", "/doppel/bus/0/1x/events",
                            "/doppel/bus/+1/0/events", "/doppel/bus/-1/0/events", "/doppel/bus/4294967296/0/events",
                            "/doppel/bus/0/1/events/more", "doppel/bus/0/1/events", "/Doppel/bus/0/1/events"}) {
    EXPECT_FALSE(parse_bus_topic(topic).has_value()) << topic;
  }
}

TEST(RecordingTopics, EachContentNamesItsMessageTypeAsItsSchema) {
  EXPECT_EQ(message_type(Content::kRun), "doppel.recording.RunInfo");
  EXPECT_EQ(message_type(Content::kWorld), "doppel.recording.WorldState");
  EXPECT_EQ(message_type(Content::kServos), "doppel.recording.ServoTables");
  EXPECT_EQ(message_type(Content::kScene), "doppel.recording.Scene");
  EXPECT_EQ(message_type(Content::kScenePoses), "doppel.recording.ScenePoses");
  EXPECT_EQ(message_type(Content::kFaults), "doppel.recording.FaultList");
  EXPECT_EQ(message_type(Content::kSummary), "doppel.recording.RecordingSummary");
  EXPECT_EQ(message_type(Content::kCamera), "doppel.recording.CameraImage");
  EXPECT_EQ(message_type(Content::kBusTransactions), "doppel.recording.BusTransaction");
  EXPECT_EQ(message_type(Content::kBusInput), "doppel.recording.BusNoise");
  EXPECT_EQ(message_type(Content::kBusEvents), "doppel.recording.BusEvent");
  EXPECT_EQ(message_type(Content::kUnknown), "");
}

// MCAP's protobuf profile: the schema data is a FileDescriptorSet that holds the message's file and
// every file it imports, so that a reader without the .proto can decode it.
TEST(RecordingTopics, TheSchemaDataIsAFileDescriptorSetWithTheMessageAndItsImports) {
  google::protobuf::FileDescriptorSet sut;

  ASSERT_TRUE(sut.ParseFromString(protobuf_schema(*BusTransaction::descriptor())));

  std::set<std::string> names;
  bool has_message = false;
  for (const google::protobuf::FileDescriptorProto& file : sut.file()) {
    EXPECT_TRUE(names.insert(file.name()).second) << file.name() << " twice";
    for (const auto& message : file.message_type()) {
      has_message = has_message || (file.package() == "doppel.recording" && message.name() == "BusTransaction");
    }
    for (const std::string& dependency : file.dependency()) {
      EXPECT_TRUE(names.count(dependency)) << file.name() << " comes before its import " << dependency;
    }
  }
  EXPECT_TRUE(has_message);
}

}  // namespace
}  // namespace doppel::recording
