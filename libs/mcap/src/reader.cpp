#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <queue>
#include <set>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "compression.h"
#include "format.h"
#include "mcap/mcap.h"

namespace doppel::mcap {

namespace f = format;

namespace {

// A chunk record's place in the file, from the summary's Chunk Index or from the scan.
struct ChunkRef {
  uint64_t offset = 0;  // of the record's opcode
  uint64_t length = 0;  // of the whole record
  uint64_t start_time = 0;
  uint64_t end_time = 0;
  std::map<uint16_t, uint64_t> message_index_offsets;  // empty: unknown
};

// A Message record in the data section, outside any chunk.
struct LooseMessage {
  uint64_t log_time = 0;
  uint64_t offset = 0;  // of the record's content
  uint64_t length = 0;  // of the content
  uint16_t channel_id = 0;
};

// One message of a decompressed chunk (or a loose one), as the merge orders them.
struct Entry {
  uint64_t log_time = 0;
  uint64_t source = 0;  // file offset of the chunk, or of the loose message
  uint64_t offset = 0;  // of the record content inside the chunk's records
  uint64_t length = 0;  // of the content
  auto key() const { return std::tie(log_time, source, offset); }
};

const char* op_name(uint8_t op) {
  switch (op) {
    case f::kHeader: return "Header";
    case f::kFooter: return "Footer";
    case f::kSchema: return "Schema";
    case f::kChannel: return "Channel";
    case f::kMessage: return "Message";
    case f::kChunk: return "Chunk";
    case f::kMessageIndex: return "Message Index";
    case f::kChunkIndex: return "Chunk Index";
    case f::kAttachment: return "Attachment";
    case f::kAttachmentIndex: return "Attachment Index";
    case f::kStatistics: return "Statistics";
    case f::kMetadata: return "Metadata";
    case f::kMetadataIndex: return "Metadata Index";
    case f::kSummaryOffset: return "Summary Offset";
    case f::kDataEnd: return "Data End";
    default: return "unknown";
  }
}

std::string op_label(uint8_t op) {
  char hex[8];
  std::snprintf(hex, sizeof hex, "0x%02X", op);
  return std::string(op_name(op)) + " (opcode " + hex + ")";
}

Schema parse_schema(std::string_view content) {
  f::Fields in(content);
  Schema s;
  s.id = in.u16("schema id");
  s.name = in.string("schema name");
  s.encoding = in.string("schema encoding");
  s.data = in.string("schema data");
  return s;
}

Channel parse_channel(std::string_view content) {
  f::Fields in(content);
  Channel c;
  c.id = in.u16("channel id");
  c.schema_id = in.u16("channel schema_id");
  c.topic = in.string("channel topic");
  c.message_encoding = in.string("channel message_encoding");
  c.metadata = in.string_map("channel metadata");
  return c;
}

// The fixed fields of a Chunk record and where its records lie within the content.
struct ChunkHeader {
  uint64_t start_time = 0;
  uint64_t end_time = 0;
  uint64_t uncompressed_size = 0;
  uint32_t uncompressed_crc = 0;
  std::string compression;
  uint64_t records_offset = 0;  // within the content
  uint64_t records_size = 0;
};

ChunkHeader parse_chunk_header(f::Fields& in) {
  ChunkHeader h;
  h.start_time = in.u64("chunk message_start_time");
  h.end_time = in.u64("chunk message_end_time");
  h.uncompressed_size = in.u64("chunk uncompressed_size");
  h.uncompressed_crc = in.u32("chunk uncompressed_crc");
  h.compression = in.string("chunk compression");
  h.records_size = in.u64("chunk records length");
  h.records_offset = in.position();
  if (h.records_size > in.left()) throw f::Truncated("chunk records run past the end of the chunk record");
  return h;
}

}  // namespace

struct Reader::Impl {
  std::string path;
  int fd = -1;
  uint64_t size = 0;
  std::string profile;
  std::map<uint16_t, Schema> schemas;
  std::map<uint16_t, Channel> channels;
  std::vector<std::pair<std::string, std::map<std::string, std::string>>> metadata;
  bool complete = false;
  std::string recovery_note;
  bool have_statistics = false;
  Statistics statistics;
  std::vector<ChunkRef> indexed_chunks;  // from the summary
  std::vector<ChunkRef> scanned_chunks;  // from the data section
  std::vector<LooseMessage> loose_messages;

  ~Impl() {
    if (fd >= 0) ::close(fd);
  }

  [[noreturn]] void fail(uint64_t offset, const std::string& what) const {
    throw std::runtime_error(path + ": " + what + " at byte " + std::to_string(offset));
  }

  // Reads `n` bytes at `offset` into `out`; the caller has checked they are inside the file.
  void read(uint64_t offset, uint64_t n, std::string& out) const {
    if (offset > size || n > size - offset) fail(offset, std::to_string(n) + " bytes needed past the end of the file");
    out.resize(n);
    uint64_t done = 0;
    while (done < n) {
      const ssize_t got = ::pread(fd, out.data() + done, n - done, static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) fail(offset + done, std::string("cannot read: ") + std::strerror(errno));
      if (got == 0) fail(offset + done, "the file shrank while reading");
      done += static_cast<uint64_t>(got);
    }
  }

  uint32_t crc_of(uint64_t begin, uint64_t end) const {
    uint32_t crc = 0;
    std::string block;
    for (uint64_t at = begin; at < end;) {
      const uint64_t n = std::min<uint64_t>(end - at, uint64_t{1} << 20);
      read(at, n, block);
      crc = f::crc32(crc, block.data(), block.size());
      at += n;
    }
    return crc;
  }

  void add_schema(const Schema& s) {
    if (s.id != 0) schemas.emplace(s.id, s);  // id 0 is invalid and ignored, as the spec says
  }

  // Decompresses the chunk record whose content is `content` (at `offset` in the file) into
  // `records`, checking its CRC.
  ChunkHeader open_chunk(std::string_view content, uint64_t offset, std::string& records) const {
    ChunkHeader h;
    try {
      f::Fields in(content);
      h = parse_chunk_header(in);
      compression::decompress(h.compression, content.substr(h.records_offset, h.records_size), h.uncompressed_size,
                              records);
    } catch (const std::runtime_error& e) {
      fail(offset, std::string("bad chunk: ") + e.what() + "; chunk");
    }
    if (h.uncompressed_crc != 0) {
      const uint32_t crc = f::crc32(0, records.data(), records.size());
      if (crc != h.uncompressed_crc) fail(offset, "chunk CRC mismatch (uncompressed records); chunk");
    }
    return h;
  }

  // Calls `each(op, content, offset_in_records)` for every record inside decompressed chunk records.
  template <class Each>
  void for_each_record(std::string_view records, uint64_t chunk_offset, Each&& each) const {
    uint64_t pos = 0;
    while (pos < records.size()) {
      if (records.size() - pos < f::kRecordHeaderBytes)
        fail(chunk_offset, "bad chunk: a record header is cut off at offset " + std::to_string(pos) + " of its records; chunk");
      const uint8_t op = static_cast<uint8_t>(records[pos]);
      const uint64_t len = f::get_le(records.data() + pos + 1, 8);
      if (len > records.size() - pos - f::kRecordHeaderBytes)
        fail(chunk_offset, "bad chunk: a " + op_label(op) + " record at offset " + std::to_string(pos) +
                               " of its records runs past their end; chunk");
      each(op, records.substr(pos + f::kRecordHeaderBytes, len), pos + f::kRecordHeaderBytes);
      pos += f::kRecordHeaderBytes + len;
    }
  }

  void count_message(uint16_t channel_id, uint64_t log_time) {
    if (statistics.message_count == 0 || log_time < statistics.message_start_time) statistics.message_start_time = log_time;
    if (statistics.message_count == 0 || log_time > statistics.message_end_time) statistics.message_end_time = log_time;
    ++statistics.message_count;
    ++statistics.channel_message_counts[channel_id];
  }

  void open(const std::string& p);
  void read_summary(uint64_t summary_start, uint64_t summary_end, uint64_t data_end);
  uint64_t scan(uint64_t begin, uint64_t end, bool tolerant, bool count);
};

void Reader::Impl::open(const std::string& p) {
  path = p;
  fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0) throw std::runtime_error(path + ": cannot stat: " + std::strerror(errno));
  size = static_cast<uint64_t>(st.st_size);

  std::string bytes;
  if (size < f::kMagicBytes) fail(0, "not an MCAP file: " + std::to_string(size) + " bytes, shorter than the magic");
  read(0, f::kMagicBytes, bytes);
  if (bytes != std::string_view(f::kMagic, f::kMagicBytes)) fail(0, "not an MCAP file: no MCAP magic");

  // The Header record.
  if (size - f::kMagicBytes < f::kRecordHeaderBytes) fail(f::kMagicBytes, "file ends before the Header record");
  read(f::kMagicBytes, f::kRecordHeaderBytes, bytes);
  if (static_cast<uint8_t>(bytes[0]) != f::kHeader)
    fail(f::kMagicBytes, "the first record is " + op_label(static_cast<uint8_t>(bytes[0])) + ", not a Header");
  const uint64_t header_len = f::get_le(bytes.data() + 1, 8);
  const uint64_t header_content = f::kMagicBytes + f::kRecordHeaderBytes;
  if (header_len > size - header_content) fail(f::kMagicBytes, "the Header record runs past the end of the file");
  read(header_content, header_len, bytes);
  try {
    f::Fields in(bytes);
    profile = in.string("header profile");
    in.string("header library");
  } catch (const f::Truncated& e) {
    fail(f::kMagicBytes, std::string("bad Header record: ") + e.what());
  }
  const uint64_t data_start = header_content + header_len;

  // The Footer and closing magic, when the writer got that far.
  uint64_t footer_at = 0;
  if (size - data_start >= f::kFooterRecordBytes + f::kMagicBytes) {
    read(size - f::kMagicBytes, f::kMagicBytes, bytes);
    footer_at = size - f::kMagicBytes - f::kFooterRecordBytes;
    if (bytes == std::string_view(f::kMagic, f::kMagicBytes)) {
      read(footer_at, f::kFooterRecordBytes, bytes);
      complete = static_cast<uint8_t>(bytes[0]) == f::kFooter && f::get_le(bytes.data() + 1, 8) == f::kFooterContentBytes;
    }
  }

  if (!complete) {
    statistics = {};
    scan(data_start, size, true, true);
    return;
  }

  const uint64_t summary_start = f::get_le(bytes.data() + 9, 8);
  const uint64_t summary_offset_start = f::get_le(bytes.data() + 17, 8);
  const uint32_t summary_crc = static_cast<uint32_t>(f::get_le(bytes.data() + 25, 4));
  if (summary_start != 0 && (summary_start < data_start || summary_start > footer_at))
    fail(footer_at, "the footer's summary_start " + std::to_string(summary_start) + " is outside the file's records");
  if (summary_offset_start != 0 &&
      (summary_offset_start < std::max(summary_start, data_start) || summary_offset_start > footer_at))
    fail(footer_at, "the footer's summary_offset_start " + std::to_string(summary_offset_start) +
                        " is outside the summary");
  const uint64_t data_end = summary_start != 0 ? summary_start : (summary_offset_start != 0 ? summary_offset_start : footer_at);
  if (summary_start != 0 && summary_crc != 0) {
    // From the start of the summary through the footer's summary_offset_start field.
    const uint32_t crc = crc_of(summary_start, footer_at + f::kRecordHeaderBytes + 16);
    if (crc != summary_crc) fail(summary_start, "summary CRC mismatch (summary section and footer)");
  }
  if (summary_start != 0) read_summary(summary_start, summary_offset_start != 0 ? summary_offset_start : footer_at, data_end);

  const bool count = !have_statistics;
  if (count) statistics = {};
  scan(data_start, data_end, false, count);
}

void Reader::Impl::read_summary(uint64_t summary_start, uint64_t summary_end, uint64_t data_end) {
  std::string summary;
  read(summary_start, summary_end - summary_start, summary);
  uint64_t pos = 0;
  while (pos < summary.size()) {
    const uint64_t at = summary_start + pos;
    if (summary.size() - pos < f::kRecordHeaderBytes) fail(at, "a summary record header runs past the end of the summary");
    const uint8_t op = static_cast<uint8_t>(summary[pos]);
    const uint64_t len = f::get_le(summary.data() + pos + 1, 8);
    if (len > summary.size() - pos - f::kRecordHeaderBytes)
      fail(at, "the summary's " + op_label(op) + " record runs past the end of the summary");
    const std::string_view content(summary.data() + pos + f::kRecordHeaderBytes, len);
    try {
      f::Fields in(content);
      switch (op) {
        case f::kSchema:
          add_schema(parse_schema(content));
          break;
        case f::kChannel: {
          Channel c = parse_channel(content);
          channels.emplace(c.id, std::move(c));
          break;
        }
        case f::kChunkIndex: {
          ChunkRef c;
          c.start_time = in.u64("message_start_time");
          c.end_time = in.u64("message_end_time");
          c.offset = in.u64("chunk_start_offset");
          c.length = in.u64("chunk_length");
          c.message_index_offsets = in.u16_u64_map("message_index_offsets");
          if (c.offset < f::kMagicBytes || c.offset > data_end || c.length < f::kRecordHeaderBytes ||
              c.length > data_end - c.offset)
            fail(at, "a Chunk Index points outside the data section (chunk at " + std::to_string(c.offset) +
                         ", " + std::to_string(c.length) + " bytes)");
          indexed_chunks.push_back(std::move(c));
          break;
        }
        case f::kStatistics: {
          Statistics s;
          s.message_count = in.u64("message_count");
          in.u16("schema_count");
          in.u32("channel_count");
          in.u32("attachment_count");
          in.u32("metadata_count");
          s.chunk_count = in.u32("chunk_count");
          s.message_start_time = in.u64("message_start_time");
          s.message_end_time = in.u64("message_end_time");
          s.channel_message_counts = in.u16_u64_map("channel_message_counts");
          statistics = std::move(s);
          have_statistics = true;
          break;
        }
        case f::kMetadataIndex: {
          const uint64_t offset = in.u64("metadata offset");
          const uint64_t length = in.u64("metadata length");
          if (offset > data_end || length < f::kRecordHeaderBytes || length > data_end - offset)
            fail(at, "a Metadata Index points outside the data section");
          std::string record;
          read(offset, length, record);
          if (static_cast<uint8_t>(record[0]) != f::kMetadata ||
              f::get_le(record.data() + 1, 8) != length - f::kRecordHeaderBytes)
            fail(offset, "a Metadata Index points at no Metadata record");
          f::Fields m(std::string_view(record).substr(f::kRecordHeaderBytes));
          std::string name(m.string("metadata name"));
          metadata.emplace_back(std::move(name), m.string_map("metadata"));
          break;
        }
        default:
          break;  // other and unknown records: skipped, as the spec says
      }
    } catch (const f::Truncated& e) {
      fail(at, "bad " + op_label(op) + " record in the summary: " + e.what());
    }
    pos += f::kRecordHeaderBytes + len;
  }
}

// Walks the data section's records from `begin` to `end`. Tolerant (no footer): a record cut off by
// the end of the file ends the walk and says so in recovery_note; otherwise it is an error. With
// `count`, chunks are decompressed to count their messages and find their schemas and channels.
// Returns where the walk stopped.
uint64_t Reader::Impl::scan(uint64_t begin, uint64_t end, bool tolerant, bool count) {
  const bool use_summary_metadata = !metadata.empty();
  std::string content;
  std::string records;
  uint64_t pos = begin;
  std::string stop;
  bool data_end_seen = false;
  while (pos < end) {
    if (end - pos < f::kRecordHeaderBytes) {
      if (!tolerant) fail(pos, "a record header runs past the end of the data section");
      stop = "the file ends in a cut-off record header at byte " + std::to_string(pos);
      break;
    }
    read(pos, f::kRecordHeaderBytes, content);
    const uint8_t op = static_cast<uint8_t>(content[0]);
    const uint64_t len = f::get_le(content.data() + 1, 8);
    if (len > end - pos - f::kRecordHeaderBytes) {
      if (!tolerant) fail(pos, "the " + op_label(op) + " record (" + std::to_string(len) + " bytes) runs past the end of the data section");
      stop = "the file ends in a " + std::string(op_name(op)) + " record cut off at byte " + std::to_string(pos) +
             " (it needs " + std::to_string(len + f::kRecordHeaderBytes) + " bytes, " + std::to_string(end - pos) +
             " are there)";
      break;
    }
    const uint64_t content_at = pos + f::kRecordHeaderBytes;
    try {
      switch (op) {
        case f::kSchema:
          read(content_at, len, content);
          add_schema(parse_schema(content));
          break;
        case f::kChannel: {
          read(content_at, len, content);
          Channel c = parse_channel(content);
          channels.emplace(c.id, std::move(c));
          break;
        }
        case f::kMessage: {
          if (len < f::kMessagePrefixBytes) throw f::Truncated("a Message record is shorter than its fixed fields");
          read(content_at, f::kMessagePrefixBytes, content);
          f::Fields in(content);
          LooseMessage m;
          m.channel_id = in.u16("channel_id");
          in.u32("sequence");
          m.log_time = in.u64("log_time");
          m.offset = content_at;
          m.length = len;
          loose_messages.push_back(m);
          if (count) count_message(m.channel_id, m.log_time);
          break;
        }
        case f::kChunk: {
          ChunkRef c;
          c.offset = pos;
          c.length = f::kRecordHeaderBytes + len;
          if (count) {
            read(content_at, len, content);
            const ChunkHeader h = open_chunk(content, pos, records);
            c.start_time = h.start_time;
            c.end_time = h.end_time;
            for_each_record(records, pos, [&](uint8_t inner, std::string_view r, uint64_t) {
              try {
                if (inner == f::kSchema) add_schema(parse_schema(r));
                if (inner == f::kChannel) {
                  Channel ch = parse_channel(r);
                  channels.emplace(ch.id, std::move(ch));
                }
                if (inner == f::kMessage) {
                  f::Fields in(r);
                  const uint16_t channel = in.u16("channel_id");
                  in.u32("sequence");
                  count_message(channel, in.u64("log_time"));
                }
              } catch (const f::Truncated& e) {
                fail(pos, "bad " + op_label(inner) + " record inside the chunk: " + e.what() + "; chunk");
              }
            });
            ++statistics.chunk_count;
          } else {
            read(content_at, std::min<uint64_t>(len, 16), content);
            f::Fields in(content);
            c.start_time = in.u64("chunk message_start_time");
            c.end_time = in.u64("chunk message_end_time");
          }
          scanned_chunks.push_back(std::move(c));
          break;
        }
        case f::kMetadata: {
          if (use_summary_metadata) break;
          read(content_at, len, content);
          f::Fields in(content);
          std::string name(in.string("metadata name"));
          metadata.emplace_back(std::move(name), in.string_map("metadata"));
          break;
        }
        case f::kDataEnd: {
          read(content_at, std::min<uint64_t>(len, 4), content);
          f::Fields in(content);
          const uint32_t expected = in.u32("data_section_crc");
          if (expected != 0 && crc_of(0, pos) != expected) fail(pos, "data section CRC mismatch (Data End record)");
          stop = "the file ends after the data section at byte " + std::to_string(content_at + len) +
                 " (the summary or footer is missing or cut off)";
          data_end_seen = true;
          break;
        }
        default:
          break;  // Message Index, Attachment, private and unknown records: skipped, as the spec says
      }
    } catch (const f::Truncated& e) {
      fail(pos, "bad " + op_label(op) + " record: " + e.what());
    }
    pos = content_at + len;
    if (data_end_seen) break;
  }
  if (tolerant) {
    if (stop.empty()) stop = "the file ends after the record ending at byte " + std::to_string(pos);
    recovery_note = "no footer: " + stop + " (was the writer killed?); " + std::to_string(scanned_chunks.size()) +
                    " complete chunk" + (scanned_chunks.size() == 1 ? "" : "s") + " read";
  }
  return pos;
}

Reader::Reader(const std::string& path) : impl_(new Impl) {
  try {
    impl_->open(path);
  } catch (...) {
    delete impl_;
    throw;
  }
}

Reader::~Reader() { delete impl_; }

const std::map<uint16_t, Schema>& Reader::schemas() const { return impl_->schemas; }
const std::map<uint16_t, Channel>& Reader::channels() const { return impl_->channels; }
const std::string& Reader::profile() const { return impl_->profile; }
Statistics Reader::statistics() const { return impl_->statistics; }
const std::vector<std::pair<std::string, std::map<std::string, std::string>>>& Reader::metadata() const {
  return impl_->metadata;
}
bool Reader::complete() const { return impl_->complete; }
const std::string& Reader::recovery_note() const { return impl_->recovery_note; }

namespace {

// The messages of one chunk (or the loose ones) still to be visited, in (log_time, file order).
struct Cursor {
  std::string records;  // decompressed chunk records; empty for loose messages
  bool loose = false;
  std::vector<Entry> entries;
  std::size_t next = 0;
  const Entry& top() const { return entries[next]; }
};

struct LaterFirst {
  bool operator()(const Cursor* a, const Cursor* b) const { return b->top().key() < a->top().key(); }
};

}  // namespace

bool Reader::for_each_message(const std::function<bool(const Message&)>& visit, const ReadOptions& options) const {
  const Impl& m = *impl_;
  const bool by_topic = !options.topics.empty();
  std::set<uint16_t> wanted;
  if (by_topic) {
    for (const auto& [id, channel] : m.channels)
      if (std::find(options.topics.begin(), options.topics.end(), channel.topic) != options.topics.end())
        wanted.insert(id);
    if (wanted.empty()) return true;
  }
  auto in_range = [&](uint64_t t) {
    return (!options.start_ns || t >= *options.start_ns) && (!options.end_ns || t < *options.end_ns);
  };
  auto wanted_channel = [&](uint16_t id) { return !by_topic || wanted.count(id) != 0; };

  // Chunks that may hold wanted messages, by start time.
  std::vector<const ChunkRef*> chunks;
  for (const ChunkRef& c : m.indexed_chunks.empty() ? m.scanned_chunks : m.indexed_chunks) {
    if (options.start_ns && c.end_time < *options.start_ns) continue;
    if (options.end_ns && c.start_time >= *options.end_ns) continue;
    if (by_topic && !c.message_index_offsets.empty() &&
        std::none_of(wanted.begin(), wanted.end(), [&](uint16_t id) { return c.message_index_offsets.count(id) != 0; }))
      continue;
    chunks.push_back(&c);
  }
  std::sort(chunks.begin(), chunks.end(), [](const ChunkRef* a, const ChunkRef* b) {
    return std::tie(a->offset, a->start_time) < std::tie(b->offset, b->start_time);
  });
  // A chunk indexed twice (a corrupt summary) is read once.
  chunks.erase(std::unique(chunks.begin(), chunks.end(),
                           [](const ChunkRef* a, const ChunkRef* b) { return a->offset == b->offset; }),
               chunks.end());
  std::stable_sort(chunks.begin(), chunks.end(), [](const ChunkRef* a, const ChunkRef* b) {
    return std::tie(a->start_time, a->offset) < std::tie(b->start_time, b->offset);
  });

  std::vector<std::unique_ptr<Cursor>> open;
  std::priority_queue<Cursor*, std::vector<Cursor*>, LaterFirst> heap;
  {
    auto loose = std::make_unique<Cursor>();
    loose->loose = true;
    for (const LooseMessage& l : m.loose_messages)
      if (in_range(l.log_time) && wanted_channel(l.channel_id)) loose->entries.push_back({l.log_time, l.offset, 0, l.length});
    std::sort(loose->entries.begin(), loose->entries.end(), [](const Entry& a, const Entry& b) { return a.key() < b.key(); });
    if (!loose->entries.empty()) {
      heap.push(loose.get());
      open.push_back(std::move(loose));
    }
  }

  std::string chunk_record;
  auto load = [&](const ChunkRef& c) {
    m.read(c.offset, c.length, chunk_record);
    if (static_cast<uint8_t>(chunk_record[0]) != f::kChunk ||
        f::get_le(chunk_record.data() + 1, 8) != c.length - f::kRecordHeaderBytes)
      m.fail(c.offset, "a Chunk Index points at no Chunk record");
    auto cursor = std::make_unique<Cursor>();
    m.open_chunk(std::string_view(chunk_record).substr(f::kRecordHeaderBytes), c.offset, cursor->records);
    m.for_each_record(cursor->records, c.offset, [&](uint8_t op, std::string_view r, uint64_t at) {
      if (op != f::kMessage) return;
      if (r.size() < f::kMessagePrefixBytes) m.fail(c.offset, "bad chunk: a Message record shorter than its fixed fields; chunk");
      const uint16_t channel = static_cast<uint16_t>(f::get_le(r.data(), 2));
      const uint64_t log_time = f::get_le(r.data() + 6, 8);
      if (in_range(log_time) && wanted_channel(channel)) cursor->entries.push_back({log_time, c.offset, at, r.size()});
    });
    std::sort(cursor->entries.begin(), cursor->entries.end(), [](const Entry& a, const Entry& b) { return a.key() < b.key(); });
    if (!cursor->entries.empty()) {
      heap.push(cursor.get());
      open.push_back(std::move(cursor));
    }
  };

  std::string loose_content;
  std::size_t next_chunk = 0;
  for (;;) {
    // Open every chunk that may hold a message before the earliest one at hand.
    while (next_chunk < chunks.size() && (heap.empty() || chunks[next_chunk]->start_time <= heap.top()->top().log_time))
      load(*chunks[next_chunk++]);
    if (heap.empty()) return true;
    Cursor* cursor = heap.top();
    heap.pop();
    const Entry& e = cursor->top();
    std::string_view content;
    if (cursor->loose) {
      m.read(e.source, e.length, loose_content);
      content = loose_content;
    } else {
      content = std::string_view(cursor->records).substr(e.offset, e.length);
    }
    Message msg;
    msg.channel_id = static_cast<uint16_t>(f::get_le(content.data(), 2));
    msg.sequence = static_cast<uint32_t>(f::get_le(content.data() + 2, 4));
    msg.log_time_ns = f::get_le(content.data() + 6, 8);
    msg.publish_time_ns = f::get_le(content.data() + 14, 8);
    msg.data = std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(content.data()) + f::kMessagePrefixBytes,
                                        content.size() - f::kMessagePrefixBytes);
    if (!visit(msg)) return false;
    if (++cursor->next < cursor->entries.size()) {
      heap.push(cursor);
    } else {
      cursor->records = std::string();
      cursor->entries = std::vector<Entry>();
    }
  }
}

}  // namespace doppel::mcap
