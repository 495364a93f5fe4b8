#include "recording/topics.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>

#include <charconv>
#include <set>

namespace doppel::recording {

namespace {

std::string_view stream_name(BusStream stream) {
  switch (stream) {
    case BusStream::kTransactions:
      return "transactions";
    case BusStream::kInput:
      return "input";
    case BusStream::kEvents:
      return "events";
  }
  return "transactions";
}

void add_file(const google::protobuf::FileDescriptor* file, std::set<std::string>& seen,
              google::protobuf::FileDescriptorSet& set) {
  if (!seen.insert(file->name()).second) return;
  for (int i = 0; i < file->dependency_count(); ++i) add_file(file->dependency(i), seen, set);
  file->CopyTo(set.add_file());
}

}  // namespace

std::string bus_topic(uint32_t robot, uint32_t bus, BusStream stream) {
  return std::string(kBusTopicPrefix) + std::to_string(robot) + "/" + std::to_string(bus) + "/" +
         std::string(stream_name(stream));
}

std::string camera_topic(std::string_view camera) { return std::string(kCameraTopicPrefix) + std::string(camera); }

std::optional<BusTopic> parse_bus_topic(std::string_view topic) {
  if (!topic.starts_with(kBusTopicPrefix)) return std::nullopt;
  std::string_view rest = topic.substr(kBusTopicPrefix.size());
  BusTopic out;
  for (uint32_t* field : {&out.robot, &out.bus}) {
    const std::size_t slash = rest.find('/');
    if (slash == std::string_view::npos || slash == 0) return std::nullopt;
    const auto [end, error] = std::from_chars(rest.data(), rest.data() + slash, *field);
    if (error != std::errc() || end != rest.data() + slash) return std::nullopt;
    rest.remove_prefix(slash + 1);
  }
  if (rest.empty() || rest.find('/') != std::string_view::npos) return std::nullopt;
  out.stream = std::string(rest);
  return out;
}

std::string protobuf_schema(const google::protobuf::Descriptor& descriptor) {
  google::protobuf::FileDescriptorSet set;
  std::set<std::string> seen;
  add_file(descriptor.file(), seen, set);
  return set.SerializeAsString();
}

}  // namespace doppel::recording
