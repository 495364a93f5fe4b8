#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

#include "compression.h"
#include "format.h"
#include "mcap/mcap.h"

namespace doppel::mcap {

namespace f = format;

namespace {

struct ChunkIndexEntry {
  uint64_t start_time = 0;
  uint64_t end_time = 0;
  uint64_t offset = 0;
  uint64_t length = 0;
  std::map<uint16_t, uint64_t> message_index_offsets;
  uint64_t message_index_length = 0;
  uint64_t compressed_size = 0;
  uint64_t uncompressed_size = 0;
};

struct MetadataIndexEntry {
  uint64_t offset = 0;
  uint64_t length = 0;
  std::string name;
};

std::string schema_record(const Schema& s) {
  std::string r;
  const std::size_t at = f::begin_record(r, f::kSchema);
  f::put_u16(r, s.id);
  f::put_string(r, s.name);
  f::put_string(r, s.encoding);
  f::put_string(r, s.data);  // uint32 length-prefixed bytes, as a string is
  f::end_record(r, at);
  return r;
}

std::string channel_record(const Channel& c) {
  std::string r;
  const std::size_t at = f::begin_record(r, f::kChannel);
  f::put_u16(r, c.id);
  f::put_u16(r, c.schema_id);
  f::put_string(r, c.topic);
  f::put_string(r, c.message_encoding);
  f::put_string_map(r, c.metadata);
  f::end_record(r, at);
  return r;
}

}  // namespace

struct Writer::Impl {
  std::string path;
  WriterOptions options;
  int fd = -1;
  bool closed = false;
  uint32_t data_crc = 0;  // of every byte written so far, while in the data section
  WriterCounters counters;
  compression::Compressor compressor;

  std::vector<Schema> schemas;    // id = index + 1
  std::vector<Channel> channels;  // id = index + 1
  std::vector<bool> schema_written;
  std::vector<bool> channel_written;
  std::map<uint16_t, uint64_t> channel_message_counts;
  uint64_t message_start_time = 0;
  uint64_t message_end_time = 0;
  uint32_t metadata_count = 0;

  // The open chunk: its uncompressed records and, per channel, (log_time, offset) of each message.
  std::string chunk;
  std::map<uint16_t, std::vector<std::pair<uint64_t, uint64_t>>> chunk_index;
  uint64_t chunk_start = 0;
  uint64_t chunk_end = 0;
  std::string compressed;  // reused between chunks
  std::string out;         // the bytes of one write, reused

  std::vector<ChunkIndexEntry> chunk_indexes;
  std::vector<MetadataIndexEntry> metadata_indexes;

  Impl(const std::string& p, const WriterOptions& o) : path(p), options(o), compressor(o.compression) {}

  [[noreturn]] void fail(const std::string& what, int err = 0) const {
    throw std::runtime_error(path + ": " + what + (err != 0 ? std::string(": ") + std::strerror(err) : ""));
  }

  // Writes `bytes` with write(2): once this returns, a killed process leaves them in the file.
  void emit(std::string_view bytes, bool in_data_section) {
    if (fd < 0) fail("the MCAP writer is closed");
    std::size_t done = 0;
    while (done < bytes.size()) {
      const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
      if (n < 0) {
        if (errno == EINTR) continue;
        fail("cannot write", errno);
      }
      done += static_cast<std::size_t>(n);
    }
    if (in_data_section) data_crc = f::crc32(data_crc, bytes.data(), bytes.size());
    counters.bytes += bytes.size();
  }

  void ensure_written(uint16_t channel_id) {
    const Channel& c = channels[channel_id - 1];
    out.clear();
    if (c.schema_id != 0 && !schema_written[c.schema_id - 1]) {
      out += schema_record(schemas[c.schema_id - 1]);
      schema_written[c.schema_id - 1] = true;
    }
    out += channel_record(c);
    channel_written[channel_id - 1] = true;
    emit(out, true);
  }

  void close_chunk() {
    if (chunk.empty()) return;
    compressor.compress(chunk, compressed);
    ChunkIndexEntry entry;
    entry.start_time = chunk_start;
    entry.end_time = chunk_end;
    entry.offset = counters.bytes;
    entry.compressed_size = compressed.size();
    entry.uncompressed_size = chunk.size();

    out.clear();
    const std::size_t at = f::begin_record(out, f::kChunk);
    f::put_u64(out, chunk_start);
    f::put_u64(out, chunk_end);
    f::put_u64(out, chunk.size());
    f::put_u32(out, f::crc32(0, chunk.data(), chunk.size()));
    f::put_string(out, compression::name(options.compression));
    f::put_u64(out, compressed.size());
    out += compressed;
    f::end_record(out, at);
    entry.length = out.size();

    // One Message Index record per channel with messages in the chunk, right after it.
    for (const auto& [channel_id, entries] : chunk_index) {
      entry.message_index_offsets[channel_id] = entry.offset + out.size();
      const std::size_t index_at = f::begin_record(out, f::kMessageIndex);
      f::put_u16(out, channel_id);
      f::put_u32(out, static_cast<uint32_t>(entries.size() * 16));
      for (const auto& [log_time, offset] : entries) {
        f::put_u64(out, log_time);
        f::put_u64(out, offset);
      }
      f::end_record(out, index_at);
    }
    entry.message_index_length = out.size() - entry.length;
    emit(out, true);

    chunk_indexes.push_back(std::move(entry));
    chunk.clear();
    chunk_index.clear();
    ++counters.chunks;
  }

  void write_summary() {
    close_chunk();
    out.clear();
    f::put_u8(out, f::kDataEnd);
    f::put_u64(out, 4);
    f::put_u32(out, data_crc);
    emit(out, false);

    // The summary, grouped by opcode; each group's place goes into a Summary Offset record.
    const uint64_t summary_start = counters.bytes;
    std::string summary;
    std::vector<std::tuple<uint8_t, uint64_t, uint64_t>> groups;
    auto group = [&](uint8_t op, auto&& fill) {
      const std::size_t begin = summary.size();
      fill();
      if (summary.size() > begin) groups.emplace_back(op, summary_start + begin, summary.size() - begin);
    };
    group(f::kSchema, [&] {
      for (const Schema& s : schemas) summary += schema_record(s);
    });
    group(f::kChannel, [&] {
      for (const Channel& c : channels) summary += channel_record(c);
    });
    group(f::kStatistics, [&] {
      const std::size_t at = f::begin_record(summary, f::kStatistics);
      f::put_u64(summary, counters.messages);
      f::put_u16(summary, static_cast<uint16_t>(schemas.size()));
      f::put_u32(summary, static_cast<uint32_t>(channels.size()));
      f::put_u32(summary, 0);  // attachments
      f::put_u32(summary, metadata_count);
      f::put_u32(summary, static_cast<uint32_t>(chunk_indexes.size()));
      f::put_u64(summary, message_start_time);
      f::put_u64(summary, message_end_time);
      std::string counts;
      for (const auto& [id, n] : channel_message_counts) {
        f::put_u16(counts, id);
        f::put_u64(counts, n);
      }
      f::put_u32(summary, static_cast<uint32_t>(counts.size()));
      summary += counts;
      f::end_record(summary, at);
    });
    group(f::kChunkIndex, [&] {
      for (const ChunkIndexEntry& c : chunk_indexes) {
        const std::size_t at = f::begin_record(summary, f::kChunkIndex);
        f::put_u64(summary, c.start_time);
        f::put_u64(summary, c.end_time);
        f::put_u64(summary, c.offset);
        f::put_u64(summary, c.length);
        std::string offsets;
        for (const auto& [id, offset] : c.message_index_offsets) {
          f::put_u16(offsets, id);
          f::put_u64(offsets, offset);
        }
        f::put_u32(summary, static_cast<uint32_t>(offsets.size()));
        summary += offsets;
        f::put_u64(summary, c.message_index_length);
        f::put_string(summary, compression::name(options.compression));
        f::put_u64(summary, c.compressed_size);
        f::put_u64(summary, c.uncompressed_size);
        f::end_record(summary, at);
      }
    });
    group(f::kMetadataIndex, [&] {
      for (const MetadataIndexEntry& m : metadata_indexes) {
        const std::size_t at = f::begin_record(summary, f::kMetadataIndex);
        f::put_u64(summary, m.offset);
        f::put_u64(summary, m.length);
        f::put_string(summary, m.name);
        f::end_record(summary, at);
      }
    });
    const uint64_t summary_offset_start = summary_start + summary.size();
    for (const auto& [op, start, length] : groups) {
      const std::size_t at = f::begin_record(summary, f::kSummaryOffset);
      f::put_u8(summary, op);
      f::put_u64(summary, start);
      f::put_u64(summary, length);
      f::end_record(summary, at);
    }
    f::put_u8(summary, f::kFooter);
    f::put_u64(summary, f::kFooterContentBytes);
    f::put_u64(summary, summary_start);
    f::put_u64(summary, summary_offset_start);
    // The summary CRC covers the summary up to and including the footer's summary_offset_start.
    f::put_u32(summary, f::crc32(0, summary.data(), summary.size()));
    summary.append(f::kMagic, f::kMagicBytes);
    emit(summary, false);
  }
};

Writer::Writer(const std::string& path, const WriterOptions& options) : impl_(new Impl(path, options)) {
  impl_->fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (impl_->fd < 0) {
    const int err = errno;
    delete impl_;
    throw std::runtime_error(path + ": cannot create the MCAP file: " + std::strerror(err));
  }
  try {
    std::string head(f::kMagic, f::kMagicBytes);
    const std::size_t at = f::begin_record(head, f::kHeader);
    f::put_string(head, options.profile);
    f::put_string(head, options.library);
    f::end_record(head, at);
    impl_->emit(head, true);
  } catch (...) {
    ::close(impl_->fd);
    delete impl_;
    throw;
  }
}

Writer::~Writer() {
  try {
    close();
  } catch (...) {  // the destructor cannot report; close() does
  }
  if (impl_->fd >= 0) ::close(impl_->fd);
  delete impl_;
}

uint16_t Writer::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  if (impl_->closed) impl_->fail("add_schema after close");
  if (impl_->schemas.size() >= 0xFFFF) impl_->fail("more than 65535 schemas");
  Schema s;
  s.id = static_cast<uint16_t>(impl_->schemas.size() + 1);
  s.name = name;
  s.encoding = encoding;
  s.data = data;
  impl_->schemas.push_back(std::move(s));
  impl_->schema_written.push_back(false);
  return impl_->schemas.back().id;
}

uint16_t Writer::add_channel(uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                             const std::map<std::string, std::string>& metadata) {
  if (impl_->closed) impl_->fail("add_channel after close");
  if (schema_id > impl_->schemas.size())
    impl_->fail("add_channel \"" + topic + "\": unknown schema id " + std::to_string(schema_id));
  if (impl_->channels.size() >= 0xFFFF) impl_->fail("more than 65535 channels");
  Channel c;
  c.id = static_cast<uint16_t>(impl_->channels.size() + 1);
  c.schema_id = schema_id;
  c.topic = topic;
  c.message_encoding = message_encoding;
  c.metadata = metadata;
  impl_->channels.push_back(std::move(c));
  impl_->channel_written.push_back(false);
  return impl_->channels.back().id;
}

void Writer::write(uint16_t channel_id, uint32_t sequence, uint64_t log_time_ns, uint64_t publish_time_ns,
                   std::span<const uint8_t> data) {
  Impl& m = *impl_;
  if (m.closed) m.fail("write after close");
  if (channel_id == 0 || channel_id > m.channels.size()) m.fail("write: unknown channel id " + std::to_string(channel_id));
  if (!m.channel_written[channel_id - 1]) m.ensure_written(channel_id);

  if (m.chunk.empty()) {
    m.chunk_start = log_time_ns;
    m.chunk_end = log_time_ns;
  }
  m.chunk_start = std::min(m.chunk_start, log_time_ns);
  m.chunk_end = std::max(m.chunk_end, log_time_ns);
  m.chunk_index[channel_id].emplace_back(log_time_ns, m.chunk.size());
  f::put_u8(m.chunk, f::kMessage);
  f::put_u64(m.chunk, f::kMessagePrefixBytes + data.size());
  f::put_u16(m.chunk, channel_id);
  f::put_u32(m.chunk, sequence);
  f::put_u64(m.chunk, log_time_ns);
  f::put_u64(m.chunk, publish_time_ns);
  m.chunk.append(reinterpret_cast<const char*>(data.data()), data.size());

  if (m.counters.messages == 0) {
    m.message_start_time = log_time_ns;
    m.message_end_time = log_time_ns;
  }
  m.message_start_time = std::min(m.message_start_time, log_time_ns);
  m.message_end_time = std::max(m.message_end_time, log_time_ns);
  ++m.channel_message_counts[channel_id];
  ++m.counters.messages;
  if (m.chunk.size() >= m.options.chunk_size) m.close_chunk();
}

void Writer::add_metadata(const std::string& name, const std::map<std::string, std::string>& values) {
  Impl& m = *impl_;
  if (m.closed) m.fail("add_metadata after close");
  std::string record;
  const std::size_t at = f::begin_record(record, f::kMetadata);
  f::put_string(record, name);
  f::put_string_map(record, values);
  f::end_record(record, at);
  m.metadata_indexes.push_back({m.counters.bytes, record.size(), name});
  m.emit(record, true);
  ++m.metadata_count;
}

void Writer::flush() {
  if (impl_->closed) return;
  impl_->close_chunk();
}

void Writer::close() {
  Impl& m = *impl_;
  if (m.closed) return;
  m.closed = true;
  m.write_summary();
  const int fd = m.fd;
  m.fd = -1;
  if (::close(fd) != 0) m.fail("cannot close", errno);
}

WriterCounters Writer::counters() const noexcept { return impl_->counters; }

}  // namespace doppel::mcap
