#pragma once
// Reads a `doppel --record` file through mcap::Reader and says what each channel carries (topics.h):
// the one place that turns a topic back into "the run info", "robot 0's bus 1 transactions" or
// "camera HEAD_CAMERA". It decodes no message: the analyzer and replay decide what they keep and
// how strict they are (the analyzer refuses a channel whose schema is not its message type, replay
// skips it with a warning). A file cut off by a kill is read up to its last complete chunk
// (recovery_note() says so). Allocates and reads files: not for real-time threads.

#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "mcap/mcap.h"

namespace doppel::recording {

// What a channel carries, from its topic alone.
enum class Content : uint8_t {
  kUnknown,          // not a doppel --record topic (or a bus topic with another stream)
  kRun,              // RunInfo
  kWorld,            // WorldState
  kServos,           // ServoTables
  kScene,            // Scene
  kScenePoses,       // ScenePoses
  kFaults,           // FaultList
  kSummary,          // RecordingSummary
  kCamera,           // CameraImage of `camera`
  kBusTransactions,  // BusTransaction of `robot`, `bus`
  kBusInput,         // BusNoise of `robot`, `bus`
  kBusEvents,        // BusEvent of `robot`, `bus`
};

// The full name of the message type a content carries ("doppel.recording.RunInfo"): the schema name
// its channel must have. "" for kUnknown.
const std::string& message_type(Content content);

struct Channel {
  uint16_t id = 0;
  std::string topic;
  Content content = Content::kUnknown;
  uint32_t robot = 0;             // bus contents
  uint32_t bus = 0;               // bus contents
  std::string camera;             // kCamera: the name after "/doppel/camera/"
  std::string message_encoding;   // kEncoding in a doppel recording
  std::string schema_name;        // "" when the channel has no schema
  // The channel is protobuf and its schema is named after the message type its content carries.
  bool schema_matches() const;
};

class Reader {
 public:
  // Opens and checks `path` (mcap::Reader). Throws std::runtime_error naming the file and what is
  // wrong (not MCAP, a bad CRC, a record past the end of the file).
  explicit Reader(const std::string& path);

  // Every channel of the file, by id.
  const std::map<uint16_t, Channel>& channels() const noexcept { return channels_; }
  // True when the file was closed by its writer (it has a footer).
  bool complete() const { return mcap_.complete(); }
  // "" for a complete file; otherwise where reading stopped (mcap::Reader::recovery_note()).
  const std::string& recovery_note() const { return mcap_.recovery_note(); }
  mcap::Statistics statistics() const { return mcap_.statistics(); }

  // Calls `visit` for every message of the channels `wanted` picks (every channel when `wanted` is
  // empty, which also passes messages on channels the file never declared, as kUnknown with no
  // topic), in log-time order; stops when `visit` returns false. When `wanted` picks no channel, no
  // message is read. Throws std::runtime_error on a corrupt chunk (mcap::Reader::for_each_message).
  void for_each(const std::function<bool(const Channel&, const mcap::Message&)>& visit,
                const std::function<bool(const Channel&)>& wanted = {}) const;

 private:
  mcap::Reader mcap_;
  std::map<uint16_t, Channel> channels_;
};

}  // namespace doppel::recording
