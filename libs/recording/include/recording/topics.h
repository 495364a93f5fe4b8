#pragma once
// The topics of a `doppel --record` file (docs/recording.md, "What is recorded") and the schema
// each channel names: every message is protobuf (libs/proto/recording.proto), and a channel's schema is
// its message type's full name ("doppel.recording.BusTransaction") with a FileDescriptorSet of the
// type's file and its imports. The recorder writes by these, the analyzer and replay read by them
// (reader.h); a topic or schema said anywhere else would be a second copy that can drift.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace google::protobuf {
class Descriptor;
}

namespace doppel::recording {

inline constexpr std::string_view kRunTopic = "/doppel/run";                  // RunInfo, once
inline constexpr std::string_view kWorldTopic = "/doppel/world";              // WorldState
inline constexpr std::string_view kServosTopic = "/doppel/servos";            // ServoTables
inline constexpr std::string_view kSceneTopic = "/doppel/scene";              // Scene
inline constexpr std::string_view kScenePosesTopic = "/doppel/scene_poses";   // ScenePoses
inline constexpr std::string_view kFaultsTopic = "/doppel/faults";            // FaultList
inline constexpr std::string_view kSummaryTopic = "/doppel/summary";          // RecordingSummary, at the end
inline constexpr std::string_view kCameraTopicPrefix = "/doppel/camera/";     // + camera name: CameraImage
inline constexpr std::string_view kBusTopicPrefix = "/doppel/bus/";           // + "<robot>/<bus>/<stream>"

// Every channel's message encoding and its schema's encoding.
inline constexpr std::string_view kEncoding = "protobuf";

// What one bus topic carries.
enum class BusStream : uint8_t {
  kTransactions,  // "transactions": BusTransaction, every instruction
  kInput,         // "input": BusNoise, driver bytes that were not part of a framed packet
  kEvents,        // "events": BusEvent, connect / hang_up
};

// "/doppel/bus/<robot>/<bus>/<stream>".
std::string bus_topic(uint32_t robot, uint32_t bus, BusStream stream);
// "/doppel/camera/<camera>".
std::string camera_topic(std::string_view camera);

// A bus topic taken apart: robot and bus are decimal numbers, `stream` the last part as written
// (an unknown one is kept, so that a reader can name it).
struct BusTopic {
  uint32_t robot = 0;
  uint32_t bus = 0;
  std::string stream;  // "transactions", "input", "events", or what else the file says
};
// None for any topic that is not "/doppel/bus/<number>/<number>/<non-empty part without '/'>".
std::optional<BusTopic> parse_bus_topic(std::string_view topic);

// The schema data MCAP stores for a protobuf message type: a FileDescriptorSet of its file and every
// file it imports, serialized.
std::string protobuf_schema(const google::protobuf::Descriptor& descriptor);

}  // namespace doppel::recording
