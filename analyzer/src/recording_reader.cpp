#include "analyzer/recording_reader.h"

#include <charconv>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "mcap/mcap.h"

namespace doppel::analyzer {

namespace {

constexpr const char* kTransactionSchema = "doppel.recording.BusTransaction";
constexpr const char* kRunSchema = "doppel.recording.RunInfo";
constexpr const char* kSummarySchema = "doppel.recording.RecordingSummary";

enum class Content : uint8_t { kRun, kTransactions, kSummary };

// "/doppel/bus/<robot>/<bus>/transactions" -> robot, bus.
bool parse_transactions_topic(const std::string& topic, uint32_t& robot, uint32_t& bus) {
  const std::string head = "/doppel/bus/";
  const std::string tail = "/transactions";
  if (topic.rfind(head, 0) != 0 || topic.size() <= head.size() + tail.size() ||
      topic.compare(topic.size() - tail.size(), tail.size(), tail) != 0) {
    return false;
  }
  const std::string middle = topic.substr(head.size(), topic.size() - head.size() - tail.size());
  const std::size_t slash = middle.find('/');
  if (slash == std::string::npos) return false;
  const char* begin = middle.data();
  const auto r1 = std::from_chars(begin, begin + slash, robot);
  const auto r2 = std::from_chars(begin + slash + 1, begin + middle.size(), bus);
  return r1.ec == std::errc() && r1.ptr == begin + slash && r2.ec == std::errc() && r2.ptr == begin + middle.size();
}

}  // namespace

BusSelector parse_bus_selector(const std::string& text) {
  BusSelector s;
  const std::size_t slash = text.find('/');
  const char* begin = text.data();
  if (slash != std::string::npos) {
    const auto r1 = std::from_chars(begin, begin + slash, s.robot);
    const auto r2 = std::from_chars(begin + slash + 1, begin + text.size(), s.bus);
    if (slash > 0 && r1.ec == std::errc() && r1.ptr == begin + slash && r2.ec == std::errc() &&
        r2.ptr == begin + text.size() && slash + 1 < text.size()) {
      return s;
    }
  }
  throw std::invalid_argument("--bus '" + text + "': expected ROBOT/BUS, two numbers such as 0/1");
}

std::string transactions_topic(uint32_t robot, uint32_t bus) {
  return "/doppel/bus/" + std::to_string(robot) + "/" + std::to_string(bus) + "/transactions";
}

Recording read_recording(const std::string& path, const std::optional<BusSelector>& only,
                         const std::function<void(const ReadProgress&)>& progress, bool require_transactions) {
  Recording out;
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw std::runtime_error(path + ": is a directory, not a recording");
  out.file_bytes = std::filesystem::file_size(path, error);
  if (error) throw std::runtime_error(path + ": " + error.message());
  try {
    mcap::Reader reader(path);
    out.recovery_note = reader.recovery_note();
    out.complete = reader.complete();

    // Which channels hold what; schemas are checked by name and encoding.
    std::map<uint16_t, Content> content;  // channel id -> what it carries
    mcap::ReadOptions options;
    for (const auto& [id, channel] : reader.channels()) {
      uint32_t robot = 0;
      uint32_t bus = 0;
      Content c;
      const char* expected = nullptr;
      if (channel.topic == kRunTopic) {
        c = Content::kRun;
        expected = kRunSchema;
      } else if (channel.topic == kSummaryTopic) {
        c = Content::kSummary;
        expected = kSummarySchema;
      } else if (parse_transactions_topic(channel.topic, robot, bus)) {
        if (only && (robot != only->robot || bus != only->bus)) continue;
        c = Content::kTransactions;
        expected = kTransactionSchema;
      } else {
        continue;
      }
      const auto schema = reader.schemas().find(channel.schema_id);
      if (channel.message_encoding != "protobuf" || schema == reader.schemas().end() || schema->second.name != expected) {
        throw std::runtime_error("channel " + channel.topic + " is not protobuf " + expected);
      }
      content[id] = c;
      options.topics.push_back(channel.topic);
    }
    bool any_transactions = false;
    for (const auto& [id, c] : content) any_transactions = any_transactions || c == Content::kTransactions;
    if (!any_transactions && !require_transactions) return out;
    if (!any_transactions) {
      std::string message = only ? "no transactions of bus " + std::to_string(only->robot) + "/" + std::to_string(only->bus) +
                                       " (topic " + transactions_topic(only->robot, only->bus) + ")"
                                 : "no bus transactions (no topic /doppel/bus/<robot>/<bus>/transactions): was it "
                                   "recorded by doppel --record?";
      if (!out.recovery_note.empty()) message += " The file is incomplete: " + out.recovery_note;
      throw std::runtime_error(message);
    }

    ReadProgress p;
    const mcap::Statistics statistics = reader.statistics();
    for (const auto& [id, c] : content) {
      const auto it = statistics.channel_message_counts.find(id);
      if (it != statistics.channel_message_counts.end()) p.total_messages += it->second;
    }
    recording::BusTransaction parsed;  // reused: only the compact copies are kept
    reader.for_each_message(
        [&](const mcap::Message& message) {
          const auto kind = content.find(message.channel_id);
          if (kind == content.end()) return true;
          const int size = static_cast<int>(message.data.size());
          if (kind->second == Content::kRun) {
            if (!out.run.ParseFromArray(message.data.data(), size)) {
              throw std::runtime_error("the message on /doppel/run is not a " + std::string(kRunSchema));
            }
            out.have_run = true;
          } else if (kind->second == Content::kSummary) {
            if (!out.summary.ParseFromArray(message.data.data(), size)) {
              throw std::runtime_error("the message on /doppel/summary is not a " + std::string(kSummarySchema));
            }
            out.have_summary = true;
          } else {
            if (!parsed.ParseFromArray(message.data.data(), size)) {
              throw std::runtime_error("message " + std::to_string(p.messages) + " (log time " +
                                       std::to_string(message.log_time_ns) + " ns) is not a " + kTransactionSchema);
            }
            out.transactions.push_back(compact(parsed));
          }
          ++p.messages;
          p.message_bytes += message.data.size();
          if (progress) progress(p);
          return true;
        },
        options);
    out.messages = p.messages;
    out.message_bytes = p.message_bytes;
    if (out.transactions.empty() && require_transactions) {
      std::string message = "the transaction topics hold no message";
      if (!out.recovery_note.empty()) message += ". The file is incomplete: " + out.recovery_note;
      throw std::runtime_error(message);
    }
  } catch (const std::exception& e) {
    const std::string what = e.what();
    // mcap::Reader names the file itself; everything else gets it in front.
    throw std::runtime_error(what.find(path) != std::string::npos ? what : path + ": " + what);
  }
  return out;
}

}  // namespace doppel::analyzer
