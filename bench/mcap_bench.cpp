// MCAP writer throughput per chunk compression (figures in docs/benchmarks.md): BusTransaction
// messages as `doppel --record` writes them (a Protocol 2.0 sync-read round of 20 servos: one
// instruction, 20 statuses with their model times) into 1 MiB chunks. Bytes/s counts message
// payload bytes; `ratio` is file size over payload size.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "mcap/mcap.h"
#include "proto/recording.pb.h"

namespace {

// `n` serialized transactions with advancing times and varying present positions.
std::vector<std::string> transactions(int n) {
  std::vector<std::string> out;
  int64_t t_ns = 1'000'000'000;
  for (int i = 0; i < n; ++i) {
    doppel::recording::BusTransaction tx;
    tx.set_robot(0);
    tx.set_bus(0);
    tx.set_sequence(static_cast<uint64_t>(i));
    tx.set_protocol(2);
    tx.set_instruction(std::string("\xFF\xFF\xFD\x00\xFE\x1B\x00\x82\x84\x00\x04\x00", 12) + std::string(20, '\x01') +
                       "\x3C\x9A");
    tx.set_checksum_ok(true);
    tx.set_baud_bps(3'000'000);
    tx.set_first_seen_ns(t_ns);
    tx.set_seen_ns(t_ns + 90'000);
    tx.set_instruction_start_ns(t_ns + 1000);
    tx.set_instruction_end_ns(t_ns + 112'000);
    int64_t s_ns = t_ns + 120'000;
    for (uint32_t id = 1; id <= 20; ++id) {
      doppel::recording::Status* s = tx.add_statuses();
      s->set_id(id);
      std::string bytes("\xFF\xFF\xFD\x00\x00\x08\x00\x55\x00", 9);
      bytes[4] = static_cast<char>(id);
      const int position = 2048 + ((i * 7 + static_cast<int>(id) * 13) % 200) - 100;
      bytes += std::string{static_cast<char>(position & 0xFF), static_cast<char>(position >> 8), 0, 0};
      bytes += std::string{static_cast<char>(i * 31 + id), static_cast<char>(id * 3)};
      s->set_bytes(bytes);
      s->set_start_ns(s_ns);
      s->set_end_ns(s_ns + 50'000);
      s->set_return_delay_us(0);
      s_ns += 55'000;
    }
    tx.set_due_ns(s_ns + 1'000'000);
    tx.set_written_ns(s_ns + 1'020'000);
    tx.set_adapter_latency_ms(1);
    tx.set_adapter("ftdi");
    out.push_back(tx.SerializeAsString());
    t_ns += 8'000'000;
  }
  return out;
}

void writer_throughput(benchmark::State& state) {
  const auto compression = static_cast<doppel::mcap::Compression>(state.range(0));
  static const std::vector<std::string> messages = transactions(20'000);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("doppel-mcap-bench-" + std::to_string(::getpid()) + ".mcap")).string();
  uint64_t payload = 0;
  uint64_t file = 0;
  for (auto _ : state) {
    doppel::mcap::WriterOptions options;
    options.compression = compression;
    doppel::mcap::Writer w(path, options);
    const uint16_t channel =
        w.add_channel(w.add_schema("doppel.recording.BusTransaction", "protobuf", ""), "/doppel/bus/0/0/transactions",
                      "protobuf");
    uint64_t t = 0;
    for (const std::string& m : messages) {
      w.write(channel, static_cast<uint32_t>(t), t, t, {reinterpret_cast<const uint8_t*>(m.data()), m.size()});
      payload += m.size();
      t += 8'000'000;
    }
    w.close();
    file += w.counters().bytes;
  }
  std::filesystem::remove(path);
  state.SetBytesProcessed(static_cast<int64_t>(payload));
  state.counters["ratio"] = static_cast<double>(file) / static_cast<double>(payload);
  state.counters["msg_bytes"] = static_cast<double>(messages.front().size());
}
BENCHMARK(writer_throughput)->ArgName("none0_zstd1_lz4_2")->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace
