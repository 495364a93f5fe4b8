#pragma once
// A recording of `doppel --record` (libs/proto/recording.proto in MCAP) held for replay: per topic the
// messages' serialized bytes in log-time order, decoded only when a moment is asked for. Keeping
// the bytes, not decoded messages, is what makes a 10-minute recording fit: a decoded WorldState
// allocates a string per joint name, several times its wire size (docs/replay.md has the
// figures). Bus transactions are not kept: they are folded into counters at load time (the
// viewer's bus counters); doppel-replay --bus reads them itself (bus_replay.h). Setup code: loads
// allocate and may throw; lookups are cheap and thread-compatible (const).

#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "contract/simulation.h"
#include "proto/recording.pb.h"

namespace doppel::replay {

// The messages of one topic in log-time order, kept as their serialized bytes.
class Track {
 public:
  // Appends a message; times must not decrease (the reader hands them in log-time order).
  void add(int64_t time_ns, std::span<const uint8_t> bytes);
  std::size_t size() const noexcept { return times_ns_.size(); }
  bool empty() const noexcept { return times_ns_.empty(); }
  // The last message at or before `time_ns` (latest-before: no interpolation); none when `time_ns`
  // is before the first. Binary search.
  std::optional<std::size_t> at_or_before(int64_t time_ns) const noexcept;
  int64_t time_ns(std::size_t i) const noexcept { return times_ns_[i]; }
  std::string_view bytes(std::size_t i) const noexcept;
  // Gives back the index' spare capacity (called once loading is done).
  void shrink();
  // Memory this track holds: message bytes plus the index.
  std::size_t held_bytes() const noexcept;

  // Messages are packed into blocks of this size (a larger message gets a block of its own), so
  // loading never copies what it has already stored, as one growing buffer would (twice the
  // memory at each doubling).
  static constexpr std::size_t kBlockBytes = std::size_t{1} << 20;

 private:
  struct Where {
    uint32_t block;
    uint32_t size;
    std::size_t offset;
  };
  std::vector<int64_t> times_ns_;
  std::vector<Where> where_;
  std::vector<std::string> blocks_;
};

// A bus' counters as of `time_ns` (cumulative from the start of the recording).
struct CounterPoint {
  int64_t time_ns = 0;
  contract::BusCounters counters;
};

// Counters are kept at most every kCounterPeriodNs (not per transaction): a 1 kHz control loop
// over 10 minutes is 600 000 transactions per bus, 6 000 points per minute is plenty for a viewer.
inline constexpr int64_t kCounterPeriodNs = 10'000'000;

class Recording {
 public:
  // Reads `path` through recording::Reader. Throws std::runtime_error naming the file and what is wrong
  // (not MCAP, corrupt, no recording.proto topics at all). A file cut off by a kill is read up to
  // its last complete chunk (recovery_note() says so).
  explicit Recording(const std::string& path);

  const std::string& path() const noexcept { return path_; }
  // The run info (default-constructed when the recording has none).
  const recording::RunInfo& run() const noexcept { return run_; }
  const std::optional<recording::RecordingSummary>& summary() const noexcept { return summary_; }
  // Log time (CLOCK_MONOTONIC of the recording machine) of recording time 0: the first message.
  int64_t origin_ns() const noexcept { return origin_ns_; }
  // Recording time (ns from origin) of the first world state (0 without one) and of the last message.
  int64_t start_ns() const noexcept { return start_ns_; }
  int64_t end_ns() const noexcept { return end_ns_; }

  // Tracks, times in recording time (ns from origin).
  const Track& world() const noexcept { return world_; }
  const Track& scene() const noexcept { return scene_; }
  const Track& scene_poses() const noexcept { return scene_poses_; }
  const Track& servos() const noexcept { return servos_; }
  const std::map<std::string, Track>& cameras() const noexcept { return cameras_; }
  // Per (robot, bus): counters at most every kCounterPeriodNs, from transactions, input noise and
  // connect / hang-up events. collisions and late_deliveries cannot be told from a recording: 0.
  const std::map<std::pair<uint32_t, uint32_t>, std::vector<CounterPoint>>& bus_counters() const noexcept {
    return bus_counters_;
  }

  // Messages read per topic, and what was skipped (unknown topics, undecodable messages).
  const std::map<std::string, uint64_t>& topic_counts() const noexcept { return topic_counts_; }
  const std::vector<std::string>& warnings() const noexcept { return warnings_; }
  const std::string& recovery_note() const noexcept { return recovery_note_; }
  // Memory the kept messages and indexes take, bytes.
  std::size_t held_bytes() const noexcept;

 private:
  std::string path_;
  recording::RunInfo run_;
  std::optional<recording::RecordingSummary> summary_;
  int64_t origin_ns_ = 0, start_ns_ = 0, end_ns_ = 0;
  Track world_, scene_, scene_poses_, servos_;
  std::map<std::string, Track> cameras_;
  std::map<std::pair<uint32_t, uint32_t>, std::vector<CounterPoint>> bus_counters_;
  std::map<std::string, uint64_t> topic_counts_;
  std::vector<std::string> warnings_;
  std::string recovery_note_;
};

}  // namespace doppel::replay
