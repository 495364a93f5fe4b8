#pragma once
// `doppel --record FILE.mcap`: writes every bus transaction and the simulation's state to an MCAP
// file (docs/recording.md) from a thread of its own. The bus threads only push events into their
// fixed TrafficTaps and the simulation thread each state it publishes into a fixed queue (servo
// tables, scene and camera stills are read from what it already publishes for the viewer). So
// recording never blocks either: when this thread falls behind, a tap or the state queue drops and
// the summary says how many.
// Finished chunks are flushed every second, so a killed doppel leaves a readable file.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "bus/traffic_tap.h"
#include "contract/host.h"
#include "mcap/mcap.h"
#include "proto/recording.pb.h"

namespace doppel::record {

struct RecorderOptions {
  std::string path;                     // the .mcap file (created or truncated)
  mcap::Compression compression = mcap::Compression::kZstd;
  double servo_hz = 10.0;               // /doppel/servos (the servo tables refresh every 100 ms)
  double scene_hz = 30.0;               // /doppel/scene_poses
  double camera_hz = 0.0;               // /doppel/camera/<name> stills; 0 = no camera images
  std::chrono::milliseconds flush_every{1000};  // a kill loses at most this much
  bool progress = false;                // a progress line on `progress_out` (a terminal) every second
};

// A bus to record: its tap (which its BusServer writes) and what it is.
struct RecordedBus {
  bus::TrafficTap* tap = nullptr;
  recording::BusInfo info;
};

// What the recording wrote and lost.
struct RecorderTotals {
  uint64_t messages = 0;
  uint64_t transactions = 0;
  uint64_t bytes = 0;
  uint64_t dropped_bus_events = 0;  // taps were full: transactions missing
  uint64_t dropped_world_states = 0;  // the state queue was full: world states missing
};

class Recorder {
 public:
  // Opens `options.path` and writes the run information. `control`'s simulation (null: no servo
  // tables, scene or stills) and faults (null: none), `world_states` (null: no world state) and
  // every tap must outlive the recorder. Throws std::runtime_error naming the file.
  Recorder(const RecorderOptions& options, recording::RunInfo run, std::vector<RecordedBus> buses,
           contract::Facets control, contract::StateQueue* world_states, std::ostream* progress_out = nullptr);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  void start();
  // Drains the taps (call after the bus threads stopped, so that nothing is lost), writes the
  // summary and closes the file. Idempotent. Errors are reported in summary(), not thrown.
  void stop();

  RecorderTotals totals() const;
  // One line per fact for the user at exit: file, messages, size, drops, any write error.
  std::string summary() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace doppel::record
