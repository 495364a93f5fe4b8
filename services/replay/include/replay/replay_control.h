#pragma once
// A recording served through the simulation-control contract (contract::Simulation and
// contract::Replay), so the web viewer and doppel-ctl show a replay as they show a live doppel:
// state(), scene(), buses() and camera_still() answer for the replay's current position, pause / resume / step / reset drive
// the playback, and anything that would change the world (place, push, ball) is refused (kConflict).
// Each answer is the last recorded message at or before the position (latest-before, no
// interpolation: world state at 100 Hz, scene poses at 30 Hz, servo tables at 10 Hz). Messages are
// decoded when asked for; the last one of each kind is kept decoded, so a paused replay polled by
// the viewer decodes nothing. Thread-safe (one mutex: HTTP worker threads, never a real-time one).

#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "contract/host.h"
#include "replay/playback.h"
#include "replay/recording.h"

namespace doppel::replay {

class ReplayControl final : public contract::Simulation, public contract::Replay {
 public:
  // Wall clock in ns (CLOCK_MONOTONIC by default; tests pass their own). `recording` must outlive this.
  using Clock = std::function<int64_t()>;
  explicit ReplayControl(const Recording& recording, Clock clock = {});

  contract::SimState state() override;
  contract::Outcome pause() override;
  contract::Outcome resume() override;
  // Only while paused (kConflict "pause first" otherwise, as live): moves the position on by `steps` ms
  // at once (a replay has nothing to simulate), stopping at the end.
  contract::Outcome step(uint32_t steps) override;
  // Back to the start of the recording; playing or paused as before.
  contract::Outcome reset() override;
  contract::Outcome place(std::size_t robot, double x_m, double y_m, double yaw_rad) override;
  contract::Outcome push(std::size_t robot, double fx_n, double fy_n, double fz_n, uint32_t steps) override;
  contract::Outcome ball(double x_m, double y_m) override;
  contract::Scene scene() override;
  std::vector<contract::BusTable> buses() override;
  contract::Result<contract::CameraStill> camera_still(const std::string& name) override;
  contract::ReplayStatus replay() override;
  contract::Outcome change_replay(const contract::ReplayChange& change) override;
  // The analyzer's report of the recording's bus traffic (bus_analysis.h), made on the first
  // request (seconds for a long recording; the playback is not held up meanwhile) and kept. None
  // without bus transactions, or when the file cannot be read again (said once on stderr).
  std::optional<std::string> bus_analysis() override;
  // The facets doppel-replay serves: the simulation and the replay.
  contract::Facets facets() noexcept {
    contract::Facets facets;
    facets.simulation = this;
    facets.replay = this;
    return facets;
  }

 private:
  int64_t now_ns() const { return clock_(); }
  int64_t position_locked();
  const char* intern(const std::string& text);  // stable C strings for SceneShape's type and kind

  const Recording& recording_;
  Clock clock_;
  std::mutex mutex_;
  Playback playback_;
  double carpet_half_length_m_ = 0.0, carpet_half_width_m_ = 0.0;  // from the first scene's carpet
  std::set<std::string> strings_;
  // The last decoded message of each kind and its index in its track.
  std::optional<std::size_t> world_index_, scene_index_, poses_index_, servos_index_;
  contract::SimState world_;
  contract::Scene scene_;
  recording::ScenePoses poses_;
  std::vector<contract::BusTable> servos_;
  // bus_analysis(): its own lock, so that state polling goes on while it is being made.
  std::mutex analysis_mutex_;
  bool analysis_made_ = false;
  std::optional<std::string> analysis_;
};

inline constexpr const char* kReplayCannotChangeWorld = "a replay cannot change the world";

}  // namespace doppel::replay
