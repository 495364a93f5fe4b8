#pragma once
// A recording in the format of libs/proto/recording.proto, written with mcap::Writer as doppel --record
// would write it, with values that name their own time so a test can tell which message it got:
// world state k (every 10 ms from 5 ms) has robot x = 0.001 k m and sim time 0.005 + 0.01 k s; the
// robot's trunk falls over (tilt from 0 to 90 degrees over the recording) while it moves along x
// at 0.1 m/s (scene poses k every 33.333 ms: trunk at x = 0.1 t + 0.4 sin(tilt));
// servo table k (every 100 ms from 0) has Present Position k; camera still k (every 500 ms from
// 250 ms) is the bytes "still k". Used by the replay tests, the browser test and the memory
// measurement of docs/replay.md (a 10-minute recording of realistic size).

#include <algorithm>
#include <cstdint>
#include <string>

namespace doppel::testing {

struct RecordingFixture {
  double seconds = 2.0;
  int joints = 3;                  // joints per robot (the default robot has 21)
  int field_shapes = 2;            // shapes besides the robot's (the default field has about 60)
  double transactions_per_s = 200; // P1 READs of ID 1's Present Position on bus 0/0
  bool camera = true;
  bool zstd = true;
};

inline constexpr int64_t kFixtureOriginNs = 5'000'000'000;  // log time of the first message
inline double fixture_x_m(int64_t world_index) { return 0.001 * static_cast<double>(world_index); }
inline double fixture_tilt_rad(double t_s, double seconds) { return 1.5707963267948966 * std::min(1.0, t_s / seconds); }

// Writes the recording to `path`. Throws on a write error.
void write_recording_fixture(const std::string& path, const RecordingFixture& fixture);

}  // namespace doppel::testing
