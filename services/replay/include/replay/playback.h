#pragma once
// Where a replay is in its recording, as a pure function of a clock the caller passes in (no clock
// inside, so the tests drive it exactly): playing, the position moves at `speed` recording
// seconds per wall-clock second and stops at the end; a seek, a speed change or a pause takes the
// position reached so far as its new starting point. Positions are recording time, ns.

#include <cstdint>

namespace doppel::replay {

class Playback {
 public:
  // Paused at `start_ns`, speed 1. Requires start_ns <= end_ns.
  Playback(int64_t start_ns, int64_t end_ns) noexcept;

  int64_t start_ns() const noexcept { return start_ns_; }
  int64_t end_ns() const noexcept { return end_ns_; }
  // The position at wall time `now_ns`; playing stops (playing() false) once the end is reached.
  int64_t position_ns(int64_t now_ns) noexcept;
  bool playing(int64_t now_ns) noexcept;
  double speed() const noexcept { return speed_; }

  // Plays from the position reached; from the end it starts over at start_ns.
  void play(int64_t now_ns) noexcept;
  void pause(int64_t now_ns) noexcept;
  // To `position_ns`, clamped to [start_ns, end_ns]; playing stays as it was (playing on from there).
  void seek(int64_t position_ns, int64_t now_ns) noexcept;
  // `speed` > 0 (callers check the range); the position reached so far is kept.
  void set_speed(double speed, int64_t now_ns) noexcept;

 private:
  void settle(int64_t now_ns) noexcept;  // anchors the position reached at now_ns

  int64_t start_ns_, end_ns_;
  int64_t anchor_position_ns_;  // position at anchor_wall_ns_
  int64_t anchor_wall_ns_ = 0;
  double speed_ = 1.0;
  bool playing_ = false;
};

}  // namespace doppel::replay
