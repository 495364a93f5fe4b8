#include "recording/reader.h"

#include "proto/recording.pb.h"
#include "recording/topics.h"

namespace doppel::recording {

namespace {

Channel classify(const mcap::Channel& in, const std::map<uint16_t, mcap::Schema>& schemas) {
  Channel out;
  out.id = in.id;
  out.topic = in.topic;
  out.message_encoding = in.message_encoding;
  if (const auto schema = schemas.find(in.schema_id); schema != schemas.end()) out.schema_name = schema->second.name;
  const std::string& topic = in.topic;
  if (topic == kRunTopic) {
    out.content = Content::kRun;
  } else if (topic == kWorldTopic) {
    out.content = Content::kWorld;
  } else if (topic == kServosTopic) {
    out.content = Content::kServos;
  } else if (topic == kSceneTopic) {
    out.content = Content::kScene;
  } else if (topic == kScenePosesTopic) {
    out.content = Content::kScenePoses;
  } else if (topic == kFaultsTopic) {
    out.content = Content::kFaults;
  } else if (topic == kSummaryTopic) {
    out.content = Content::kSummary;
  } else if (topic.starts_with(kCameraTopicPrefix) && topic.size() > kCameraTopicPrefix.size()) {
    out.content = Content::kCamera;
    out.camera = topic.substr(kCameraTopicPrefix.size());
  } else if (const auto bus = parse_bus_topic(topic)) {
    out.robot = bus->robot;
    out.bus = bus->bus;
    out.content = bus->stream == "transactions" ? Content::kBusTransactions
                  : bus->stream == "input"      ? Content::kBusInput
                  : bus->stream == "events"     ? Content::kBusEvents
                                                : Content::kUnknown;
  }
  return out;
}

}  // namespace

const std::string& message_type(Content content) {
  static const std::string none;
  switch (content) {
    case Content::kUnknown:
      return none;
    case Content::kRun:
      return RunInfo::descriptor()->full_name();
    case Content::kWorld:
      return WorldState::descriptor()->full_name();
    case Content::kServos:
      return ServoTables::descriptor()->full_name();
    case Content::kScene:
      return Scene::descriptor()->full_name();
    case Content::kScenePoses:
      return ScenePoses::descriptor()->full_name();
    case Content::kFaults:
      return FaultList::descriptor()->full_name();
    case Content::kSummary:
      return RecordingSummary::descriptor()->full_name();
    case Content::kCamera:
      return CameraImage::descriptor()->full_name();
    case Content::kBusTransactions:
      return BusTransaction::descriptor()->full_name();
    case Content::kBusInput:
      return BusNoise::descriptor()->full_name();
    case Content::kBusEvents:
      return BusEvent::descriptor()->full_name();
  }
  return none;
}

bool Channel::schema_matches() const {
  return content != Content::kUnknown && message_encoding == kEncoding && schema_name == message_type(content);
}

Reader::Reader(const std::string& path) : mcap_(path) {
  for (const auto& [id, channel] : mcap_.channels()) channels_.emplace(id, classify(channel, mcap_.schemas()));
}

void Reader::for_each(const std::function<bool(const Channel&, const mcap::Message&)>& visit,
                      const std::function<bool(const Channel&)>& wanted) const {
  mcap::ReadOptions options;
  if (wanted) {
    for (const auto& [id, channel] : channels_) {
      if (wanted(channel)) options.topics.push_back(channel.topic);
    }
    if (options.topics.empty()) return;
  }
  mcap_.for_each_message(
      [&](const mcap::Message& message) {
        const auto channel = channels_.find(message.channel_id);
        if (channel == channels_.end()) {
          Channel undeclared;  // a message on a channel the file never declared: kUnknown, no topic
          undeclared.id = message.channel_id;
          return visit(undeclared, message);
        }
        if (wanted && !wanted(channel->second)) return true;  // another channel on a wanted topic
        return visit(channel->second, message);
      },
      options);
}

}  // namespace doppel::recording
