#pragma once
// A BusServer serving devices on its own thread over a real pty, for the bus tests that talk to it
// as a driver would (through the client helpers of pty_test_support.h).

#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "bus/bus_server.h"
#include "bus/pty_port.h"
#include "dynamixel/bus_devices.h"
#include "dynamixel/device.h"
#include "pty_test_support.h"

namespace doppel::bus::testing {

// The server runs from construction until destruction, which stops and joins its thread first.
class ServedBus {
 public:
  ServedBus(const BusServerOptions& options, const std::vector<dynamixel::Device*>& devices,
            DeviceSync* sync = nullptr)
      : port_(dir_.file("ttyDXL0")) {
    for (dynamixel::Device* d : devices) devices_.add(*d);
    server_ = std::make_unique<BusServer>(port_, devices_, options, sync);
    thread_ = std::thread([this] { server_->run(stop_); });
  }
  ~ServedBus() {
    stop_ = true;
    thread_.join();
  }
  ServedBus(const ServedBus&) = delete;
  ServedBus& operator=(const ServedBus&) = delete;

  const std::string& path() const { return port_.link_path(); }
  BusServer& server() { return *server_; }

  // Polls the diagnostics until `done` holds (or 2 s pass).
  template <class Pred>
  bool eventually(Pred done) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (std::chrono::steady_clock::now() < deadline) {
      if (done(server_->diagnostics())) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return false;
  }

  // The next reply trace (options.record_traces), waiting up to 2 s; nullopt when none came.
  std::optional<ReplyTrace> next_trace() {
    ReplyTrace trace;
    if (!eventually([&](const BusDiagnostics&) { return server_->traces().try_pop(trace); })) return std::nullopt;
    return trace;
  }

 private:
  TempDir dir_;
  PtyPort port_;
  dynamixel::BusDevices devices_;
  std::unique_ptr<BusServer> server_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Default options, but fast timing: replies as soon as they are computed.
inline BusServerOptions fast() {
  BusServerOptions options;
  options.timing_mode = TimingMode::kFast;
  return options;
}

}  // namespace doppel::bus::testing
