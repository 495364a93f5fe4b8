// Writes the fixture recording (recording_fixture.h) to a file: the browser test's recording, and
// the 10-minute recording docs/replay.md measures doppel-replay's memory with.
// usage: doppel_recording_fixture_tool OUT.mcap [SECONDS [JOINTS FIELD_SHAPES TRANSACTIONS_PER_S [CAMERA]]]
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "recording_fixture.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 7) {
    std::fprintf(stderr, "usage: %s OUT.mcap [SECONDS [JOINTS FIELD_SHAPES TRANSACTIONS_PER_S [CAMERA 0|1]]]\n", argv[0]);
    return 2;
  }
  doppel::testing::RecordingFixture fixture;
  if (argc > 2) fixture.seconds = std::atof(argv[2]);
  if (argc > 3) fixture.joints = std::atoi(argv[3]);
  if (argc > 4) fixture.field_shapes = std::atoi(argv[4]);
  if (argc > 5) fixture.transactions_per_s = std::atof(argv[5]);
  if (argc > 6) fixture.camera = std::atoi(argv[6]) != 0;
  if (fixture.seconds <= 0) {
    std::fprintf(stderr, "SECONDS must be > 0\n");
    return 2;
  }
  try {
    doppel::testing::write_recording_fixture(argv[1], fixture);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
