#pragma once
// The Bit-Bots cycle as a recording would hold it, built from real encoded packets.

#include "proto/recording.pb.h"
#include "transaction_builder.h"

namespace doppel::analyzer::testing {

inline constexpr uint32_t kFourMbps = 4'000'000;

// The Bit-Bots cycle (docs/benchmarks.md): 20 XM430 at 4 Mbps, RDT 0; per cycle a SYNC WRITE of
// Goal Position (116, 4 B each) and a SYNC READ of 126, 10 B each; recorded with 50 us firmware
// time, the driver idling 500 us between cycles.
struct BitBots {
  recording::RunInfo run;
  std::vector<recording::BusTransaction> transactions;
  Bytes sync_write;
  Bytes sync_read;
  std::size_t status_bytes = 0;
};

inline BitBots bitbots(int cycles) {
  BitBots b;
  auto* info = b.run.add_buses();
  info->set_robot(0);
  info->set_bus(0);
  info->set_link("ttyDXL0");
  info->set_configured_baud_bps(kFourMbps);
  info->set_processing_ns(50'000);
  info->set_adapter("ftdi");
  Bytes write_params{116, 0, 4, 0};
  Bytes read_params{126, 0, 10, 0};
  for (uint8_t id = 1; id <= 20; ++id) {
    auto* d = info->add_devices();
    d->set_id(id);
    d->set_model("XM430-W350");
    d->set_protocol(2);
    d->set_return_delay_us(0);
    write_params.insert(write_params.end(), {id, 0x00, 0x08, 0x00, 0x00});
    read_params.push_back(id);
  }
  b.sync_write = p2_instruction(0xFE, 0x83, write_params);
  b.sync_read = p2_instruction(0xFE, 0x82, read_params);
  std::vector<StatusSpec> statuses;
  for (uint8_t id = 1; id <= 20; ++id) {
    statuses.push_back({id, p2_status(id, {1, 0, 2, 0, 0, 0, 0x10, 0x08, 0, 0}), 0});
  }
  b.status_bytes = statuses.front().bytes.size();
  TransactionBuilder builder(0, 2, kFourMbps, 50'000);
  int64_t t = 1'000'000;
  for (int c = 0; c < cycles; ++c) {
    builder.add(t, b.sync_write, {});
    builder.add(t + 1000, b.sync_read, statuses, true);
    t = builder.last_done_ns() + 500'000;
  }
  b.transactions = builder.transactions();
  return b;
}

}  // namespace doppel::analyzer::testing
