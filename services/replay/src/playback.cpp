#include "replay/playback.h"

#include <algorithm>
#include <cmath>

namespace doppel::replay {

Playback::Playback(int64_t start_ns, int64_t end_ns) noexcept
    : start_ns_(start_ns), end_ns_(std::max(start_ns, end_ns)), anchor_position_ns_(start_ns) {}

void Playback::settle(int64_t now_ns) noexcept {
  if (playing_) {
    const double moved = static_cast<double>(now_ns - anchor_wall_ns_) * speed_;
    const double position = static_cast<double>(anchor_position_ns_) + std::max(0.0, moved);
    if (position >= static_cast<double>(end_ns_)) {
      anchor_position_ns_ = end_ns_;
      playing_ = false;
    } else {
      anchor_position_ns_ = static_cast<int64_t>(std::llround(position));
    }
  }
  anchor_wall_ns_ = now_ns;
}

int64_t Playback::position_ns(int64_t now_ns) noexcept {
  settle(now_ns);
  return anchor_position_ns_;
}

bool Playback::playing(int64_t now_ns) noexcept {
  settle(now_ns);
  return playing_;
}

void Playback::play(int64_t now_ns) noexcept {
  settle(now_ns);
  if (anchor_position_ns_ >= end_ns_) anchor_position_ns_ = start_ns_;
  playing_ = anchor_position_ns_ < end_ns_;
}

void Playback::pause(int64_t now_ns) noexcept {
  settle(now_ns);
  playing_ = false;
}

void Playback::seek(int64_t position_ns, int64_t now_ns) noexcept {
  settle(now_ns);
  anchor_position_ns_ = std::clamp(position_ns, start_ns_, end_ns_);
}

void Playback::set_speed(double speed, int64_t now_ns) noexcept {
  settle(now_ns);
  speed_ = speed;
}

}  // namespace doppel::replay
