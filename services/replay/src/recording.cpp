#include "replay/recording.h"

#include <malloc.h>

#include <algorithm>
#include <stdexcept>

#include "recording/reader.h"
#include "recording/topics.h"

namespace doppel::replay {

void Track::add(int64_t time_ns, std::span<const uint8_t> bytes) {
  if (blocks_.empty() || blocks_.back().size() + bytes.size() > blocks_.back().capacity()) {
    blocks_.emplace_back().reserve(std::max(kBlockBytes, bytes.size()));
  }
  std::string& block = blocks_.back();
  where_.push_back({static_cast<uint32_t>(blocks_.size() - 1), static_cast<uint32_t>(bytes.size()), block.size()});
  block.append(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  times_ns_.push_back(time_ns);
}

std::optional<std::size_t> Track::at_or_before(int64_t time_ns) const noexcept {
  const auto after = std::upper_bound(times_ns_.begin(), times_ns_.end(), time_ns);
  if (after == times_ns_.begin()) return std::nullopt;
  return static_cast<std::size_t>(after - times_ns_.begin()) - 1;
}

std::string_view Track::bytes(std::size_t i) const noexcept {
  const Where& w = where_[i];
  return std::string_view(blocks_[w.block]).substr(w.offset, w.size);
}

void Track::shrink() {
  times_ns_.shrink_to_fit();
  where_.shrink_to_fit();
  if (!blocks_.empty()) blocks_.back().shrink_to_fit();  // the last block is the only part-filled one worth it
}

std::size_t Track::held_bytes() const noexcept {
  std::size_t bytes = times_ns_.capacity() * sizeof(int64_t) + where_.capacity() * sizeof(Where);
  for (const std::string& block : blocks_) bytes += block.capacity();
  return bytes;
}

namespace {

// Running counters of one bus while the transactions are folded in.
struct CounterState {
  contract::BusCounters counters;
  int64_t window_start_ns = 0;
};

void add_point(std::vector<CounterPoint>& points, CounterState& state, int64_t time_ns) {
  if (points.empty() || time_ns - state.window_start_ns >= kCounterPeriodNs) {
    points.push_back({time_ns, state.counters});
    state.window_start_ns = time_ns;
  } else {
    points.back() = {time_ns, state.counters};  // still within the window: the point moves on
  }
}

}  // namespace

Recording::Recording(const std::string& path) : path_(path) {
  const recording::Reader reader(path);
  recovery_note_ = reader.recovery_note();
  // What each channel is, decided once (not per message).
  enum class Kind { kSkip, kRun, kWorld, kServos, kScene, kScenePoses, kSummary, kCamera, kTransactions, kEvents, kInput };
  struct Route {
    Kind kind = Kind::kSkip;
    std::string camera;
    std::pair<uint32_t, uint32_t> bus;
  };
  std::map<uint16_t, Route> routes;
  for (const auto& [id, channel] : reader.channels()) {
    Route route;
    const std::string& topic = channel.topic;
    const bool protobuf = channel.message_encoding == recording::kEncoding;
    if (!protobuf) {
      warnings_.push_back("topic " + topic + ": message encoding '" + channel.message_encoding + "', not protobuf: skipped");
    } else {
      route.camera = channel.camera;
      route.bus = {channel.robot, channel.bus};
      switch (channel.content) {
        case recording::Content::kRun: route.kind = Kind::kRun; break;
        case recording::Content::kWorld: route.kind = Kind::kWorld; break;
        case recording::Content::kServos: route.kind = Kind::kServos; break;
        case recording::Content::kScene: route.kind = Kind::kScene; break;
        case recording::Content::kScenePoses: route.kind = Kind::kScenePoses; break;
        case recording::Content::kSummary: route.kind = Kind::kSummary; break;
        case recording::Content::kCamera: route.kind = Kind::kCamera; break;
        case recording::Content::kBusTransactions: route.kind = Kind::kTransactions; break;
        case recording::Content::kBusEvents: route.kind = Kind::kEvents; break;
        case recording::Content::kBusInput: route.kind = Kind::kInput; break;
        case recording::Content::kFaults:
        case recording::Content::kUnknown: break;
      }
    }
    if (route.kind == Kind::kSkip && protobuf) {
      warnings_.push_back("topic " + topic + " is not one doppel-replay knows: skipped");
    }
    routes[id] = route;
  }

  std::map<std::pair<uint32_t, uint32_t>, CounterState> counter_states;
  bool first = true;
  uint64_t undecodable = 0;
  recording::BusTransaction transaction;
  recording::BusEvent event;
  recording::BusNoise noise;
  reader.for_each([&](const recording::Channel& channel, const mcap::Message& message) {
    const auto route = routes.find(channel.id);
    const int64_t log_ns = static_cast<int64_t>(message.log_time_ns);
    if (first) {
      origin_ns_ = log_ns;
      first = false;
    }
    const int64_t t_ns = log_ns - origin_ns_;
    end_ns_ = std::max(end_ns_, t_ns);
    if (route == routes.end()) return true;
    ++topic_counts_[channel.topic];
    const void* data = message.data.data();
    const int size = static_cast<int>(message.data.size());
    switch (route->second.kind) {
      case Kind::kSkip:
        break;
      case Kind::kRun:
        if (!run_.ParseFromArray(data, size)) ++undecodable;
        break;
      case Kind::kSummary: {
        recording::RecordingSummary summary;
        if (summary.ParseFromArray(data, size)) summary_ = summary; else ++undecodable;
        break;
      }
      case Kind::kWorld:
        if (world_.empty()) start_ns_ = t_ns;
        world_.add(t_ns, message.data);
        break;
      case Kind::kServos:
        servos_.add(t_ns, message.data);
        break;
      case Kind::kScene:
        scene_.add(t_ns, message.data);
        break;
      case Kind::kScenePoses:
        scene_poses_.add(t_ns, message.data);
        break;
      case Kind::kCamera:
        cameras_[route->second.camera].add(t_ns, message.data);
        break;
      case Kind::kTransactions: {
        if (!transaction.ParseFromArray(data, size)) {
          ++undecodable;
          break;
        }
        CounterState& state = counter_states[route->second.bus];
        contract::BusCounters& c = state.counters;
        ++c.packets;
        c.bytes_in += transaction.instruction().size();
        if (!transaction.checksum_ok()) ++c.bad_checksums;
        if (transaction.reply_dropped()) ++c.dropped_replies;
        if (transaction.statuses_size() > 0 && !transaction.reply_dropped()) {
          ++c.replies;
          for (const recording::Status& status : transaction.statuses()) c.bytes_out += status.bytes().size();
        }
        if (transaction.due_ns() != 0 && transaction.written_ns() != 0) {
          c.max_lateness_ns = std::max(c.max_lateness_ns, transaction.written_ns() - transaction.due_ns());
        }
        c.connected = true;  // the driver had the port open
        add_point(bus_counters_[route->second.bus], state, t_ns);
        break;
      }
      case Kind::kInput: {
        if (!noise.ParseFromArray(data, size)) {
          ++undecodable;
          break;
        }
        CounterState& state = counter_states[route->second.bus];
        state.counters.bytes_in += noise.bytes().size();
        if (noise.reason() == "timeout") ++state.counters.timeouts;
        add_point(bus_counters_[route->second.bus], state, t_ns);
        break;
      }
      case Kind::kEvents: {
        if (!event.ParseFromArray(data, size)) {
          ++undecodable;
          break;
        }
        CounterState& state = counter_states[route->second.bus];
        state.counters.connected = event.event() == "connect";
        add_point(bus_counters_[route->second.bus], state, t_ns);
        break;
      }
    }
    return true;
  });
  for (Track* track : {&world_, &scene_, &scene_poses_, &servos_}) track->shrink();
  for (auto& [name, track] : cameras_) track.shrink();
  malloc_trim(0);  // the reader's chunk buffers, freed between the kept blocks: back to the system
  if (undecodable > 0) {
    warnings_.push_back(std::to_string(undecodable) + " messages could not be decoded as their recording.proto type: skipped");
  }
  if (first) throw std::runtime_error(path + ": the recording holds no messages");
  if (world_.empty() && scene_.empty() && servos_.empty() && bus_counters_.empty()) {
    throw std::runtime_error(path + ": no doppel recording topics (" + std::string(recording::kWorldTopic) + ", " +
                             std::string(recording::kSceneTopic) + ", " + std::string(recording::kBusTopicPrefix) +
                             "...): is it a doppel --record file?");
  }
}

std::size_t Recording::held_bytes() const noexcept {
  std::size_t bytes = world_.held_bytes() + scene_.held_bytes() + scene_poses_.held_bytes() + servos_.held_bytes();
  for (const auto& [name, track] : cameras_) bytes += track.held_bytes() + name.capacity();
  for (const auto& [bus, points] : bus_counters_) bytes += points.capacity() * sizeof(CounterPoint);
  return bytes;
}

}  // namespace doppel::replay
