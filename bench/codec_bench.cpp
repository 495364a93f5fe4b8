// Protocol 1.0 parser throughput, status encoding rate, and one whole bus transaction through
// BusDevices with real device models (what the bus thread does per instruction packet).
#include <benchmark/benchmark.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "dynamixel/bus_devices.h"
#include "dynamixel/protocol1.h"
#include "dynamixel/protocol1_servo.h"

namespace {

using doppel::dynamixel::BusDevices;
using doppel::dynamixel::InstructionPacket;
using doppel::dynamixel::Protocol1Parser;
using doppel::dynamixel::Protocol1Servo;
using doppel::dynamixel::StatusPacket;
namespace dxl = doppel::dynamixel;

// A 64 KiB stream of what a walking robot's host sends: a SYNC WRITE of 20 goal positions and
// speeds, then 20 READs of Present Position, repeated.
std::vector<uint8_t> host_traffic() {
  std::vector<uint8_t> stream;
  uint8_t buffer[256];
  std::vector<uint8_t> sync = {30, 4};
  for (uint8_t id = 1; id <= 20; ++id) {
    sync.insert(sync.end(), {id, static_cast<uint8_t>(id * 7), 0x02, 0x40, 0x00});
  }
  while (stream.size() < 64 * 1024) {
    const std::size_t n = dxl::encode_protocol1_instruction(dxl::kBroadcastId, dxl::instruction::kSyncWrite,
                                                            sync.data(), sync.size(), buffer, sizeof buffer);
    stream.insert(stream.end(), buffer, buffer + n);
    for (uint8_t id = 1; id <= 20; ++id) {
      const uint8_t read[] = {36, 2};
      const std::size_t m =
          dxl::encode_protocol1_instruction(id, dxl::instruction::kRead, read, 2, buffer, sizeof buffer);
      stream.insert(stream.end(), buffer, buffer + m);
    }
  }
  return stream;
}

void BM_ParserThroughput(benchmark::State& state) {
  const std::vector<uint8_t> stream = host_traffic();
  Protocol1Parser parser;
  uint64_t packets = 0;
  for (auto _ : state) {
    for (uint8_t b : stream) {
      if (parser.push(b) == Protocol1Parser::Result::kPacket) {
        ++packets;
      }
    }
    benchmark::DoNotOptimize(packets);
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * stream.size()));
  state.counters["packets/s"] = benchmark::Counter(static_cast<double>(packets), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ParserThroughput);

void BM_EncodeStatus(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  std::vector<uint8_t> params(n, 0x5A);
  StatusPacket out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(dxl::encode_protocol1_status(1, 0, params.data(), n, out));
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * (n + 6)));
}
BENCHMARK(BM_EncodeStatus)->Arg(0)->Arg(2)->Arg(50);

// 21 servos (the FUmanoid 2011 bus): one READ of Present Position handled by every device model.
void BM_DispatchRead(benchmark::State& state) {
  std::vector<std::unique_ptr<Protocol1Servo>> servos;
  BusDevices bus;
  for (uint8_t id = 1; id <= 21; ++id) {
    servos.push_back(std::make_unique<Protocol1Servo>(dxl::model_spec(id % 3 == 0 ? "RX-28" : "RX-64"), id, 1, 0));
    bus.add(*servos.back());
  }
  InstructionPacket read;
  read.id = 11;
  read.instruction = dxl::instruction::kRead;
  read.params[0] = 36;
  read.params[1] = 2;
  read.param_count = 2;
  for (auto _ : state) {
    benchmark::DoNotOptimize(bus.dispatch(read, 1000000).size());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DispatchRead);

// 20 MX servos answering one BULK READ of 6 bytes each (chained replies).
void BM_DispatchBulkRead(benchmark::State& state) {
  std::vector<std::unique_ptr<Protocol1Servo>> servos;
  BusDevices bus;
  InstructionPacket bulk;
  bulk.id = dxl::kBroadcastId;
  bulk.instruction = dxl::instruction::kBulkRead;
  bulk.params[bulk.param_count++] = 0;
  for (uint8_t id = 1; id <= 20; ++id) {
    servos.push_back(std::make_unique<Protocol1Servo>(dxl::model_spec("MX-28"), id, 1, 0));
    bus.add(*servos.back());
    for (uint8_t b : {uint8_t{6}, id, uint8_t{36}}) {
      bulk.params[bulk.param_count++] = b;
    }
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(bus.dispatch(bulk, 1000000).size());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_DispatchBulkRead);

// Sim link of one servo per call: registers -> command, feedback -> registers.
void BM_ServoSimLink(benchmark::State& state) {
  Protocol1Servo servo(dxl::model_spec("MX-64"), 1, 1, 0);
  dxl::ServoFeedback feedback;
  for (auto _ : state) {
    feedback.position_rad += 1e-4;
    feedback.sim_time_ns += 1000000;
    servo.apply(feedback);
    benchmark::DoNotOptimize(servo.command());
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ServoSimLink);

}  // namespace
