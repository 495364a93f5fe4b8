#pragma once
// Reads what the analyzer needs from a recording (doppel --record, docs/recording.md) through
// recording::Reader: the run info, the bus transactions and what the recorder lost (the summary),
// all protobuf messages of libs/proto/recording.proto.
// A recording cut off by a kill is read as far as its finished chunks go (the reader's recovery
// note says so). Allocates and reads files: not for real-time threads.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analyzer/transaction.h"
#include "proto/recording.pb.h"

namespace doppel::analyzer {

// One bus of one robot, as --bus ROBOT/BUS names it.
struct BusSelector {
  uint32_t robot = 0;
  uint32_t bus = 0;
};
// Parses "ROBOT/BUS" (e.g. "0/1"). Throws std::invalid_argument with a sentence.
BusSelector parse_bus_selector(const std::string& text);

struct Recording {
  recording::RunInfo run;                          // empty when the file has no /doppel/run
  bool have_run = false;
  recording::RecordingSummary summary;             // the recorder's losses (empty when not written)
  bool have_summary = false;
  std::vector<Transaction> transactions;           // in log-time order
  uint64_t messages = 0;                           // messages read (all selected topics)
  uint64_t message_bytes = 0;                      // their payload bytes
  uint64_t file_bytes = 0;                         // size of the file
  std::string recovery_note;                       // mcap::Reader::recovery_note() ("" when complete)
  bool complete = false;                           // the file has its footer: the writer closed it
};

// What has been read so far, for a progress line.
struct ReadProgress {
  uint64_t messages = 0;
  uint64_t message_bytes = 0;
  uint64_t total_messages = 0;  // from the file's statistics (0: unknown)
};

// Reads `path`. `only` keeps one bus. `progress` is called after every message (the caller
// throttles). Throws std::runtime_error whose message starts with the file name and says what is
// wrong (not an MCAP file, corrupt chunk, a transaction message that is not a BusTransaction, no
// transaction topic at all). Without `require_transactions` a file with no transaction yet is not
// an error (a recording still being written: doppel-bus report --follow); its list is empty.
Recording read_recording(const std::string& path, const std::optional<BusSelector>& only = std::nullopt,
                         const std::function<void(const ReadProgress&)>& progress = {},
                         bool require_transactions = true);

}  // namespace doppel::analyzer
