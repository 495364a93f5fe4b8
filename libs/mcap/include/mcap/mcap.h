#pragma once
// MCAP, the open container Foxglove and other robotics tools read (https://mcap.dev/spec), written
// and read from the published specification: Debian packages no MCAP library. The writer keeps
// messages in chunks (zstd, lz4 or none) with message indexes and writes an indexed summary at
// close; every finished chunk is already in the file, so a killed writer leaves a file whose
// finished chunks a Reader still returns. Not for real-time threads: it allocates and writes files.

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace doppel::mcap {

enum class Compression : uint8_t { kNone, kZstd, kLz4 };

struct Schema {
  uint16_t id = 0;
  std::string name;      // e.g. "doppel.recording.BusTransaction"
  std::string encoding;  // e.g. "protobuf" (data: a serialized google.protobuf.FileDescriptorSet)
  std::string data;
};

struct Channel {
  uint16_t id = 0;
  uint16_t schema_id = 0;
  std::string topic;
  std::string message_encoding;  // e.g. "protobuf"
  std::map<std::string, std::string> metadata;
};

struct WriterOptions {
  std::string profile;                       // header profile, "" for none
  std::string library = "doppel";            // header library
  Compression compression = Compression::kZstd;
  std::size_t chunk_size = std::size_t{1} << 20;  // uncompressed bytes before a chunk is closed
};

// What a Writer has written so far.
struct WriterCounters {
  uint64_t messages = 0;
  uint64_t chunks = 0;
  uint64_t bytes = 0;  // file bytes written
};

class Writer {
 public:
  // Creates (truncates) `path` and writes the magic and header. Throws std::runtime_error naming
  // the file and the reason.
  Writer(const std::string& path, const WriterOptions& options = {});
  ~Writer();  // close()s; errors are swallowed there (call close() to see them)
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Ids from 1, in call order. Schema and channel records go into the data section before the first
  // message that uses them and again into the summary.
  uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);
  uint16_t add_channel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                       const std::map<std::string, std::string>& metadata = {});
  // Appends a message to the open chunk (closing the chunk, with its message indexes, to the file
  // when it reaches chunk_size). Throws std::runtime_error on a write error or an unknown channel.
  void write(uint16_t channel_id, uint32_t sequence, uint64_t log_time_ns, uint64_t publish_time_ns,
             std::span<const uint8_t> data);
  // A metadata record (name and key/value pairs), indexed in the summary.
  void add_metadata(const std::string& name, const std::map<std::string, std::string>& values);
  // Writes the open chunk to the file now (e.g. once a second, so a kill loses at most that much).
  void flush();
  // Closes the last chunk, writes data end, the summary (schemas, channels, chunk and metadata
  // indexes, statistics), summary offsets, footer and magic. Idempotent. Throws on a write error.
  void close();

  WriterCounters counters() const noexcept;

 private:
  struct Impl;
  Impl* impl_;
};

struct Message {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time_ns = 0;
  uint64_t publish_time_ns = 0;
  std::span<const uint8_t> data;  // valid during the callback only
};

struct Statistics {
  uint64_t message_count = 0;
  uint64_t message_start_time = 0;
  uint64_t message_end_time = 0;
  uint32_t chunk_count = 0;
  std::map<uint16_t, uint64_t> channel_message_counts;
};

struct ReadOptions {
  std::optional<uint64_t> start_ns;  // log_time >= start
  std::optional<uint64_t> end_ns;    // log_time < end
  std::vector<std::string> topics;   // empty: all
};

class Reader {
 public:
  // Opens and checks `path`: magic, header, and the footer and summary when present. A file without
  // a valid footer (writer killed) is read by scanning its records from the start; complete chunks
  // are used and recovery_note() says where the file stops. Throws std::runtime_error naming the
  // file and what is wrong (not an MCAP file, a bad CRC, a record running past the end of the file).
  explicit Reader(const std::string& path);
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  const std::map<uint16_t, Schema>& schemas() const;
  const std::map<uint16_t, Channel>& channels() const;
  const std::string& profile() const;
  // From the summary, or counted by the scan of an unfinished file.
  Statistics statistics() const;
  // Metadata records: name -> key/value pairs.
  const std::vector<std::pair<std::string, std::map<std::string, std::string>>>& metadata() const;
  // True when the file has a footer and summary (it was closed).
  bool complete() const;
  // "" for a complete file; otherwise where and why reading stopped (e.g. "no footer: the file ends
  // in a chunk cut off at byte 123456 (was the writer killed?); 12 complete chunks read").
  const std::string& recovery_note() const;

  // Calls `visit` for every message matching `options`, in log_time order (ties: file order).
  // Returns false as soon as `visit` does. Throws std::runtime_error on a corrupt chunk (bad CRC,
  // bad compression), naming the chunk's file offset.
  bool for_each_message(const std::function<bool(const Message&)>& visit, const ReadOptions& options = {}) const;

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace doppel::mcap
