#include "replay/bus_replay.h"

#include <asm/termbits.h>
#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <sstream>
#include <stdexcept>

#include "dynamixel/models.h"
#include "dynamixel/packet_framer.h"
#include "dynamixel/protocol2_models.h"
#include "recording/reader.h"
#include "recording/topics.h"

namespace doppel::replay {
namespace {

int64_t monotonic_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

std::string hex(uint8_t byte) {
  static constexpr char kDigits[] = "0123456789ABCDEF";
  return std::string("0x") + kDigits[byte >> 4] + kDigits[byte & 15];
}

std::string instruction_name(uint8_t code) {
  namespace in = dynamixel::instruction;
  switch (code) {
    case in::kPing: return "PING";
    case in::kRead: return "READ";
    case in::kWrite: return "WRITE";
    case in::kRegWrite: return "REG_WRITE";
    case in::kAction: return "ACTION";
    case in::kFactoryReset: return "FACTORY_RESET";
    case in::kReboot: return "REBOOT";
    case in::kClear: return "CLEAR";
    case in::kControlTableBackup: return "CONTROL_TABLE_BACKUP";
    case in::kSyncRead: return "SYNC_READ";
    case in::kSyncWrite: return "SYNC_WRITE";
    case in::kFastSyncRead: return "FAST_SYNC_READ";
    case in::kBulkRead: return "BULK_READ";
    case in::kBulkWrite: return "BULK_WRITE";
    case in::kFastBulkRead: return "FAST_BULK_READ";
    default: return hex(code);
  }
}

uint16_t le16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }

int64_t little_endian(std::string_view bytes) {
  uint64_t value = 0;
  for (std::size_t i = bytes.size(); i-- > 0;) value = (value << 8) | static_cast<uint8_t>(bytes[i]);
  return static_cast<int64_t>(value);
}

int64_t percentile(std::vector<int64_t> values, double p) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(p * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(rank, values.size() - 1)];
}

}  // namespace

std::vector<StatusFrame> frame_statuses(std::string_view bytes, std::size_t* unframed) {
  std::vector<StatusFrame> frames;
  dynamixel::PacketFramer framer;
  std::size_t begin = 0;  // where the bytes of the packet being framed may start
  std::size_t framed_bytes = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    if (framer.idle()) begin = i;
    if (framer.push(static_cast<uint8_t>(bytes[i])) != dynamixel::PacketFramer::Result::kPacket) continue;
    const dynamixel::InstructionPacket& packet = framer.packet();
    StatusFrame frame;
    frame.protocol = static_cast<uint8_t>(packet.protocol);
    frame.id = packet.id;
    frame.checksum_ok = packet.checksum_ok;
    const auto* params = reinterpret_cast<const char*>(packet.params.data());
    if (packet.protocol == dynamixel::Protocol::kV1) {
      frame.error = packet.instruction;  // P1 status: FF FF ID LEN ERR PARAMS CHKSUM
      frame.params.assign(params, packet.param_count);
    } else if (packet.param_count > 0) {  // P2 status: ... 0x55 ERR PARAMS CRC
      frame.error = packet.params[0];
      frame.params.assign(params + 1, packet.param_count - 1u);
    }
    // The packet's wire bytes: from its header (the framer drops bytes before it) to here.
    const std::size_t header = bytes.substr(begin, i + 1 - begin).find(packet.protocol == dynamixel::Protocol::kV1
                                                                           ? std::string_view("\xFF\xFF", 2)
                                                                           : std::string_view("\xFF\xFF\xFD\x00", 4));
    const std::size_t start = header == std::string_view::npos ? begin : begin + header;
    frame.bytes = std::string(bytes.substr(start, i + 1 - start));
    framed_bytes += frame.bytes.size();
    frames.push_back(std::move(frame));
  }
  if (unframed != nullptr) *unframed = bytes.size() - framed_bytes;
  return frames;
}

Instruction parse_instruction(std::string_view bytes) {
  Instruction out;
  dynamixel::PacketFramer framer;
  for (const char c : bytes) {
    if (framer.push(static_cast<uint8_t>(c)) != dynamixel::PacketFramer::Result::kPacket) continue;
    const dynamixel::InstructionPacket& p = framer.packet();
    out.framed = true;
    out.protocol = static_cast<uint8_t>(p.protocol);
    out.id = p.id;
    out.code = p.instruction;
    out.name = instruction_name(p.instruction);
    const uint8_t* q = p.params.data();
    const std::size_t n = p.param_count;
    namespace in = dynamixel::instruction;
    if (p.protocol == dynamixel::Protocol::kV1) {
      if (p.instruction == in::kRead && n >= 2) out.reads.push_back({p.id, q[0], q[1]});
      if (p.instruction == in::kBulkRead && n >= 1) {
        for (std::size_t k = 1; k + 3 <= n; k += 3) out.reads.push_back({q[k + 1], q[k + 2], q[k]});
      }
      if (p.instruction == in::kSyncRead && n >= 2) {  // MX(2.0)-style in P1 firmware: addr, len, IDs
        for (std::size_t k = 2; k < n; ++k) out.reads.push_back({q[k], q[0], q[1]});
      }
    } else {
      if (p.instruction == in::kRead && n >= 4) out.reads.push_back({p.id, le16(q), le16(q + 2)});
      if (p.instruction == in::kSyncRead && n >= 4) {
        for (std::size_t k = 4; k < n; ++k) out.reads.push_back({q[k], le16(q), le16(q + 2)});
      }
      if (p.instruction == in::kBulkRead) {
        for (std::size_t k = 0; k + 5 <= n; k += 5) out.reads.push_back({q[k], le16(q + k + 1), le16(q + k + 3)});
      }
    }
    break;
  }
  if (!out.framed) out.name = "unframed bytes";
  return out;
}

RegisterNames::RegisterNames(const recording::BusInfo& bus) {
  for (const recording::DeviceInfo& device : bus.devices()) models_[static_cast<uint8_t>(device.id())] = device.model();
}

RegisterNames::Register RegisterNames::at(uint8_t id, uint8_t protocol, uint16_t address) const {
  Register out;
  out.address = address;
  out.name = "address " + std::to_string(address);
  // The e-Manuals' EEPROM areas when the model is not known: P1 0..23, P2 (X series) 0..63.
  out.eeprom = protocol == 1 ? address < 24 : address < 64;
  const auto model = models_.find(id);
  if (model == models_.end()) return out;
  if (protocol == 1) {
    for (const dynamixel::ModelSpec* spec : dynamixel::known_models()) {
      if (spec->name != model->second || address > 0xFF) continue;
      if (const dynamixel::RegisterSpec* r = dynamixel::find_register(spec->registers, static_cast<uint8_t>(address))) {
        return {std::string(r->name), r->address, r->size, r->area == dynamixel::Area::kEeprom, true};
      }
    }
  } else if (const dynamixel::P2ModelSpec* spec = dynamixel::find_p2_model(model->second)) {
    if (const dynamixel::P2RegisterSpec* r = dynamixel::find_p2_register(spec->registers, address)) {
      return {std::string(r->name), r->address, r->size, r->area == dynamixel::Area::kEeprom, true};
    }
  }
  return out;
}

const char* verdict_name(Verdict verdict) noexcept {
  switch (verdict) {
    case Verdict::kMatched: return "matched";
    case Verdict::kValues: return "values differ (RAM registers)";
    case Verdict::kDiffered: return "differed";
    case Verdict::kMissing: return "missing";
    case Verdict::kUnexpected: return "unexpected";
  }
  return "?";
}

TransactionResult compare_transaction(const recording::BusTransaction& recorded, std::string_view replayed,
                                      const RegisterNames& names) {
  TransactionResult result;
  result.sequence = recorded.sequence();
  const Instruction instruction = parse_instruction(recorded.instruction());
  result.instruction = instruction.name + (instruction.framed ? " ID " + std::to_string(instruction.id) : "");
  std::string expected;
  for (const recording::Status& status : recorded.statuses()) expected += status.bytes();
  if (!recorded.statuses().empty() && recorded.written_ns() != 0) {
    result.recorded_reply_ns = recorded.written_ns() - recorded.first_seen_ns();
  }
  if (expected == replayed) return result;
  const std::vector<StatusFrame> want = frame_statuses(expected);
  const std::vector<StatusFrame> got = frame_statuses(replayed);
  if (expected.empty()) {
    result.verdict = Verdict::kUnexpected;
    result.note = got.empty() ? std::to_string(replayed.size()) + " bytes came back, no status packet"
                              : "ID " + std::to_string(got[0].id) + " answered; no status was recorded";
    return result;
  }
  if (got.empty()) {
    result.verdict = Verdict::kMissing;
    result.note = replayed.empty() ? "no answer" : std::to_string(replayed.size()) + " bytes came back, no whole status packet";
    return result;
  }
  result.verdict = Verdict::kValues;
  std::vector<bool> used(got.size(), false);
  std::vector<std::string> notes;
  auto differ = [&](std::string note) {
    result.verdict = Verdict::kDiffered;
    notes.push_back(std::move(note));
  };
  for (const StatusFrame& w : want) {
    std::size_t k = 0;
    while (k < got.size() && (used[k] || got[k].id != w.id)) ++k;
    const std::string who = "ID " + std::to_string(w.id);
    if (k == got.size()) {
      differ(who + ": no status (one was recorded)");
      continue;
    }
    used[k] = true;
    const StatusFrame& g = got[k];
    if (w.bytes == g.bytes) continue;
    if (!g.checksum_ok) differ(who + ": the status' checksum is wrong");
    if (w.error != g.error) differ(who + ": error byte " + hex(w.error) + " recorded, " + hex(g.error) + " now");
    if (w.params.size() != g.params.size()) {
      differ(who + ": " + std::to_string(w.params.size()) + " data bytes recorded, " + std::to_string(g.params.size()) + " now");
      continue;
    }
    if (w.params == g.params) continue;
    const auto range = std::find_if(instruction.reads.begin(), instruction.reads.end(),
                                    [&](const ReadRange& r) { return r.id == w.id && r.length == w.params.size(); });
    if (range == instruction.reads.end()) {
      differ(who + ": data bytes differ");  // a PING's model number, a FAST read block
      continue;
    }
    for (std::size_t i = 0; i < w.params.size();) {
      const RegisterNames::Register reg = names.at(w.id, w.protocol, static_cast<uint16_t>(range->address + i));
      // The register's bytes inside the range read.
      const std::size_t first = reg.known ? std::max<std::size_t>(reg.address, range->address) - range->address : i;
      const std::size_t end = reg.known ? std::min<std::size_t>(reg.address + reg.size - range->address, w.params.size()) : i + 1;
      const std::string_view a = std::string_view(w.params).substr(first, end - first);
      const std::string_view b = std::string_view(g.params).substr(first, end - first);
      if (a != b) {
        result.differences.push_back({w.id, reg.name, static_cast<uint16_t>(range->address + first), reg.eeprom,
                                      little_endian(a), little_endian(b)});
        if (reg.eeprom) differ(who + ": EEPROM register " + reg.name + " differs");
      }
      i = std::max(end, i + 1);
    }
  }
  for (std::size_t k = 0; k < got.size(); ++k) {
    if (!used[k]) differ("ID " + std::to_string(got[k].id) + " answered; no status of it was recorded");
  }
  if (result.verdict == Verdict::kValues) {
    std::string list;
    for (const RegisterDifference& d : result.differences) {
      list += (list.empty() ? "" : ", ") + ("ID " + std::to_string(d.id) + " " + d.name + " " + std::to_string(d.recorded) +
                                            " -> " + std::to_string(d.replayed));
    }
    notes.push_back(list);
  }
  for (const std::string& note : notes) result.note += (result.note.empty() ? "" : "; ") + note;
  return result;
}

int open_bus_port(const std::string& link, uint32_t baud_bps) {
  const int fd = ::open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) throw std::runtime_error("cannot open " + link + ": " + std::strerror(errno) + " (is doppel running with that link?)");
  struct termios2 tio {};
  if (::ioctl(fd, TCGETS2, &tio) != 0) {
    const int error = errno;
    ::close(fd);
    throw std::runtime_error(link + " is not a serial port (TCGETS2: " + std::strerror(error) + ")");
  }
  tio.c_iflag = IGNPAR;
  tio.c_oflag = 0;
  tio.c_lflag = 0;
  tio.c_cflag = CS8 | CLOCAL | CREAD | BOTHER;
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  tio.c_ispeed = baud_bps;
  tio.c_ospeed = baud_bps;
  if (::ioctl(fd, TCSETS2, &tio) != 0) {
    const int error = errno;
    ::close(fd);
    throw std::runtime_error("cannot set " + link + " to " + std::to_string(baud_bps) + " baud (TCSETS2: " + std::strerror(error) + ")");
  }
  return fd;
}

BusReplayer::BusReplayer(int fd, RegisterNames names, BusReplayOptions options)
    : fd_(fd), names_(std::move(names)), options_(options) {}

std::vector<TransactionResult> BusReplayer::run(const std::vector<recording::BusTransaction>& transactions,
                                                const std::function<void(std::size_t, std::size_t)>& progress) {
  std::vector<TransactionResult> results;
  results.reserve(transactions.size());
  if (transactions.empty()) return results;
  // Reads what the port has until `deadline_ns` or until `enough` says the answer is complete.
  std::string received;
  int64_t last_byte_ns = 0;
  auto read_until = [&](int64_t deadline_ns, const std::function<bool()>& enough) {
    char buffer[4096];
    while (!enough()) {
      const int64_t now = monotonic_ns();
      if (now >= deadline_ns) return;
      pollfd p{fd_, POLLIN, 0};
      const int64_t wait_ns = std::min<int64_t>(deadline_ns - now, 1'000'000'000);  // ns: poll's ms would overshoot
      const timespec wait{static_cast<time_t>(wait_ns / 1'000'000'000), static_cast<long>(wait_ns % 1'000'000'000)};
      const int ready = ::ppoll(&p, 1, &wait, nullptr);
      if (ready < 0 && errno != EINTR) throw std::runtime_error(std::string("poll on the bus port failed: ") + std::strerror(errno));
      if (ready <= 0) continue;
      if ((p.revents & (POLLHUP | POLLERR)) != 0 && (p.revents & POLLIN) == 0) {
        throw std::runtime_error("the bus port hung up (did doppel stop?)");
      }
      const ssize_t n = ::read(fd_, buffer, sizeof(buffer));
      if (n > 0) {
        received.append(buffer, static_cast<std::size_t>(n));
        last_byte_ns = monotonic_ns();
      } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
        throw std::runtime_error(std::string("reading the bus port failed: ") + std::strerror(errno));
      }
    }
  };
  const int64_t t0 = monotonic_ns();
  const int64_t first_seen0 = transactions.front().first_seen_ns();
  int64_t shift_ns = 0;  // how far the schedule has slipped behind the recording (waiting for answers)
  std::optional<std::size_t> pending;  // the transaction whose answer is still being collected
  int64_t pending_write_ns = 0, pending_late_ns = 0, pending_slip_ns = 0;
  auto finish = [&]() {
    if (!pending) return;
    TransactionResult result = compare_transaction(transactions[*pending], received, names_);
    if (!received.empty() && !frame_statuses(received).empty()) result.replayed_reply_ns = last_byte_ns - pending_write_ns;
    result.send_late_ns = pending_late_ns;
    result.schedule_slip_ns = pending_slip_ns;
    results.push_back(std::move(result));
    received.clear();
    pending.reset();
    if (progress) progress(results.size(), transactions.size());
  };
  auto scaled = [&](int64_t recorded_ns) { return static_cast<int64_t>(static_cast<double>(recorded_ns) / options_.speed); };
  for (std::size_t i = 0; i < transactions.size(); ++i) {
    const recording::BusTransaction& t = transactions[i];
    int64_t target = t0 + shift_ns + scaled(t.first_seen_ns() - first_seen0);
    // Bytes until the next instruction belong to the previous one. One that expected no answer
    // still listens for a short while even when the schedule says go (an answer where none was
    // recorded is what it is there to find); the schedule slips by that much.
    int64_t listen_until = target;
    if (pending && transactions[*pending].statuses_size() == 0) {
      const int64_t gap = scaled(t.first_seen_ns() - transactions[*pending].first_seen_ns());
      listen_until = std::max(target, pending_write_ns + std::min(gap, kMinListenNs));
    }
    read_until(listen_until, [] { return false; });
    finish();
    // Behind the schedule by more than timer jitter (an answer came late or never): the rest of
    // the recording keeps its recorded gaps from here, it does not hurry to catch up.
    int64_t slip = 0;
    if (const int64_t behind = monotonic_ns() - target; behind > kSlipThresholdNs) {
      slip = behind;
      shift_ns += behind;
      target += behind;
    }
    if (t.baud_bps() != 0 && t.baud_bps() != baud_bps_) {
      struct termios2 tio {};
      if (::ioctl(fd_, TCGETS2, &tio) == 0) {
        tio.c_cflag = (tio.c_cflag & ~CBAUD) | BOTHER;
        tio.c_ispeed = tio.c_ospeed = t.baud_bps();
        if (::ioctl(fd_, TCSETS2, &tio) != 0) throw std::runtime_error("cannot set the bus port to " + std::to_string(t.baud_bps()) + " baud");
      }
      baud_bps_ = t.baud_bps();
    }
    const int64_t write_ns = monotonic_ns();
    std::size_t written = 0;
    const std::string& bytes = t.instruction();
    while (written < bytes.size()) {
      const ssize_t n = ::write(fd_, bytes.data() + written, bytes.size() - written);
      if (n > 0) {
        written += static_cast<std::size_t>(n);
      } else if (n < 0 && errno != EAGAIN && errno != EINTR) {
        throw std::runtime_error(std::string("writing the bus port failed: ") + std::strerror(errno));
      } else {
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, 10);
      }
    }
    pending = i;
    pending_write_ns = write_ns;
    pending_late_ns = std::max<int64_t>(0, write_ns - target);
    pending_slip_ns = slip;
    // Wait for as many status packets as were recorded (as the driver did), up to the recorded
    // reply time plus the timeout; the rest of the gap to the next instruction is read above.
    const std::size_t statuses = static_cast<std::size_t>(t.statuses_size());
    if (statuses > 0) {
      const int64_t recorded_reply = t.written_ns() != 0 ? std::max<int64_t>(0, t.written_ns() - t.first_seen_ns()) : 0;
      read_until(write_ns + recorded_reply + options_.reply_timeout_ns,
                 [&] { return frame_statuses(received).size() >= statuses; });
    }
  }
  read_until(monotonic_ns() + 20'000'000, [] { return false; });  // a late or unexpected last answer
  finish();
  return results;
}

BusReplaySummary summarize(const std::vector<TransactionResult>& results) {
  BusReplaySummary summary;
  std::vector<int64_t> recorded, replayed, late;
  for (const TransactionResult& r : results) {
    ++summary.verdicts[r.verdict];
    summary.schedule_slip_ns += r.schedule_slip_ns;
    if (r.recorded_reply_ns >= 0 && r.replayed_reply_ns >= 0) {
      recorded.push_back(r.recorded_reply_ns);
      replayed.push_back(r.replayed_reply_ns);
    }
    late.push_back(r.send_late_ns);
    for (const RegisterDifference& d : r.differences) ++summary.differing_registers["ID " + std::to_string(d.id) + " " + d.name];
  }
  summary.recorded_p50_ns = percentile(recorded, 0.5);
  summary.recorded_p99_ns = percentile(recorded, 0.99);
  summary.replayed_p50_ns = percentile(replayed, 0.5);
  summary.replayed_p99_ns = percentile(replayed, 0.99);
  summary.send_late_p99_ns = percentile(late, 0.99);
  return summary;
}

std::string format_report(const std::vector<TransactionResult>& results, const BusReplaySummary& summary,
                          std::size_t max_lines, bool every) {
  std::ostringstream out;
  // What should have matched first (differed, missing, unexpected), then a few transactions whose
  // RAM values differ (the summary's register list says which and how often).
  std::size_t lines = 0, not_shown = 0, values_shown = 0, values_not_shown = 0;
  auto line = [&](const TransactionResult& r) {
    out << "#" << r.sequence << " " << r.instruction << ": " << verdict_name(r.verdict);
    if (!r.note.empty()) out << ": " << r.note;
    out << "\n";
  };
  if (every) {
    for (const TransactionResult& r : results) {
      out << "#" << r.sequence << " " << r.instruction << ": " << verdict_name(r.verdict) << ", reply "
          << (r.recorded_reply_ns >= 0 ? std::to_string(r.recorded_reply_ns / 1000) + " us" : std::string("none")) << " recorded, "
          << (r.replayed_reply_ns >= 0 ? std::to_string(r.replayed_reply_ns / 1000) + " us" : std::string("none")) << " now";
      if (!r.note.empty()) out << ": " << r.note;
      out << "\n";
    }
  }
  for (const TransactionResult& r : results) {
    if (every || r.verdict == Verdict::kMatched || r.verdict == Verdict::kValues) continue;
    if (lines++ < max_lines) line(r); else ++not_shown;
  }
  if (not_shown > 0) out << "(" << not_shown << " more transactions differed, were missing or unexpected)\n";
  const std::size_t value_lines = std::min<std::size_t>(3, max_lines);
  for (const TransactionResult& r : results) {
    if (every || r.verdict != Verdict::kValues) continue;
    if (values_shown++ < value_lines) line(r); else ++values_not_shown;
  }
  if (values_not_shown > 0) out << "(" << values_not_shown << " more transactions with RAM values that differ)\n";
  auto count = [&](Verdict v) {
    const auto found = summary.verdicts.find(v);
    return found == summary.verdicts.end() ? uint64_t{0} : found->second;
  };
  out << results.size() << " transactions: " << count(Verdict::kMatched) << " matched, " << count(Verdict::kValues)
      << " with RAM values that differ (physics), " << count(Verdict::kDiffered) << " differed, " << count(Verdict::kMissing)
      << " missing, " << count(Verdict::kUnexpected) << " unexpected\n";
  auto us = [](int64_t ns) { return std::to_string(ns / 1000); };
  out << "reply time recorded p50 " << us(summary.recorded_p50_ns) << " us, p99 " << us(summary.recorded_p99_ns)
      << " us; replayed p50 " << us(summary.replayed_p50_ns) << " us, p99 " << us(summary.replayed_p99_ns)
      << " us\ninstructions sent late p99 " << us(summary.send_late_p99_ns) << " us; the schedule slipped "
      << us(summary.schedule_slip_ns) << " us in all waiting for answers\n";
  if (!summary.differing_registers.empty()) {
    out << "registers that differed (transactions):";
    for (const auto& [name, n] : summary.differing_registers) out << " " << name << " (" << n << ")";
    out << "\n";
  }
  return out.str();
}

RecordedBus load_bus(const std::string& path, uint32_t robot, uint32_t bus) {
  const recording::Reader reader(path);
  const std::string topic = recording::bus_topic(robot, bus, recording::BusStream::kTransactions);
  RecordedBus out;
  uint64_t undecodable = 0;
  reader.for_each(
      [&](const recording::Channel& channel, const mcap::Message& message) {
        if (channel.content == recording::Content::kRun) {
          recording::RunInfo run;
          if (run.ParseFromArray(message.data.data(), static_cast<int>(message.data.size()))) {
            for (const recording::BusInfo& info : run.buses()) {
              if (info.robot() == robot && info.bus() == bus) out.info = info;
            }
          }
          return true;
        }
        recording::BusTransaction transaction;
        if (!transaction.ParseFromArray(message.data.data(), static_cast<int>(message.data.size()))) {
          ++undecodable;
          return true;
        }
        out.transactions.push_back(std::move(transaction));
        return true;
      },
      [&topic](const recording::Channel& channel) {
        return channel.content == recording::Content::kRun || channel.topic == topic;
      });
  if (undecodable > 0) {
    throw std::runtime_error(path + ": " + std::to_string(undecodable) + " messages on " + topic + " are no BusTransaction");
  }
  std::stable_sort(out.transactions.begin(), out.transactions.end(),
                   [](const auto& a, const auto& b) { return a.sequence() < b.sequence(); });
  for (std::size_t i = 1; i < out.transactions.size(); ++i) {
    const uint64_t a = out.transactions[i - 1].sequence(), b = out.transactions[i].sequence();
    if (b > a + 1) out.sequence_gaps += b - a - 1;
  }
  return out;
}

std::vector<std::pair<uint32_t, uint32_t>> recorded_buses(const std::string& path) {
  const recording::Reader reader(path);
  std::vector<std::pair<uint32_t, uint32_t>> out;
  for (const auto& [id, channel] : reader.channels()) {
    if (channel.content == recording::Content::kBusTransactions) out.emplace_back(channel.robot, channel.bus);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace doppel::replay
