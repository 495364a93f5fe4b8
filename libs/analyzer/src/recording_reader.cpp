#include "analyzer/recording_reader.h"

#include <charconv>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "recording/reader.h"
#include "recording/topics.h"

namespace doppel::analyzer {

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

Recording read_recording(const std::string& path, const std::optional<BusSelector>& only,
                         const std::function<void(const ReadProgress&)>& progress, bool require_transactions) {
  Recording out;
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) throw std::runtime_error(path + ": is a directory, not a recording");
  out.file_bytes = std::filesystem::file_size(path, error);
  if (error) throw std::runtime_error(path + ": " + error.message());
  try {
    const recording::Reader reader(path);
    out.recovery_note = reader.recovery_note();
    out.complete = reader.complete();

    // Which channels hold what; schemas are checked by name and encoding.
    std::map<uint16_t, recording::Content> content;  // channel id -> what it carries
    for (const auto& [id, channel] : reader.channels()) {
      if (channel.content == recording::Content::kBusTransactions) {
        if (only && (channel.robot != only->robot || channel.bus != only->bus)) continue;
      } else if (channel.content != recording::Content::kRun && channel.content != recording::Content::kSummary) {
        continue;
      }
      if (!channel.schema_matches()) {
        throw std::runtime_error("channel " + channel.topic + " is not protobuf " + recording::message_type(channel.content));
      }
      content[id] = channel.content;
    }
    bool any_transactions = false;
    for (const auto& [id, c] : content) any_transactions = any_transactions || c == recording::Content::kBusTransactions;
    if (!any_transactions && !require_transactions) return out;
    if (!any_transactions) {
      std::string message = only ? "no transactions of bus " + std::to_string(only->robot) + "/" + std::to_string(only->bus) +
                                       " (topic " +
                                       recording::bus_topic(only->robot, only->bus, recording::BusStream::kTransactions) + ")"
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
    reader.for_each(
        [&](const recording::Channel& channel, const mcap::Message& message) {
          const int size = static_cast<int>(message.data.size());
          if (channel.content == recording::Content::kRun) {
            if (!out.run.ParseFromArray(message.data.data(), size)) {
              throw std::runtime_error("the message on " + channel.topic + " is not a " + recording::message_type(channel.content));
            }
            out.have_run = true;
          } else if (channel.content == recording::Content::kSummary) {
            if (!out.summary.ParseFromArray(message.data.data(), size)) {
              throw std::runtime_error("the message on " + channel.topic + " is not a " + recording::message_type(channel.content));
            }
            out.have_summary = true;
          } else {
            if (!parsed.ParseFromArray(message.data.data(), size)) {
              throw std::runtime_error("message " + std::to_string(p.messages) + " (log time " +
                                       std::to_string(message.log_time_ns) + " ns) is not a " +
                                       recording::message_type(channel.content));
            }
            out.transactions.push_back(compact(parsed));
          }
          ++p.messages;
          p.message_bytes += message.data.size();
          if (progress) progress(p);
          return true;
        },
        [&content](const recording::Channel& channel) { return content.count(channel.id) != 0; });
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
