#pragma once
// The replay facet (doppel-replay, docs/replay.md): a recording served as a simulation whose
// playback can be moved, sped up and paused, with the analyzer's report of its bus traffic.

#include <optional>
#include <string>
#include <vector>

#include "contract/error.h"

namespace doppel::contract {

// Where a replay (doppel-replay, docs/replay.md) is in its recording. Times are seconds of the
// recording's clock from its first message, so a pause during the recording replays as one.
struct ReplayStatus {
  double start_s = 0.0;     // the first world state
  double end_s = 0.0;       // the last message
  double position_s = 0.0;  // the moment state(), scene(), buses() and camera_still() show
  double speed = 1.0;       // recording seconds per wall-clock second while playing
  bool playing = false;     // false: paused, or stopped at the end
  std::vector<std::string> cameras;  // cameras whose stills were recorded
};

// A change of playback; a field left empty stays as it is. All fields are checked before any applies.
struct ReplayChange {
  std::optional<double> position_s;  // seek (scrub) to this moment, within [start_s, end_s]
  std::optional<double> speed;       // kMinReplaySpeed..kMaxReplaySpeed
  std::optional<bool> playing;
};
inline constexpr double kMinReplaySpeed = 0.1;
inline constexpr double kMaxReplaySpeed = 10.0;

class Replay {
 public:
  virtual ~Replay() = default;
  virtual ReplayStatus replay() = 0;
  // Applies a change checked against replay() (fields and ranges: the HTTP layer checks them).
  virtual Outcome change_replay(const ReplayChange& change) = 0;
  // The bus analysis of the recording as a JSON document, serialised by whoever made it (the
  // analyzer, docs/analyzer.md: the contract does not know its fields). None for a recording
  // without bus traffic: the viewer then shows no Bus panel.
  virtual std::optional<std::string> bus_analysis() = 0;
};

}  // namespace doppel::contract
