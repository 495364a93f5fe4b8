#pragma once
// What a robot's world-model virtual sensor reports and how imperfectly (thesis 4.1.1: a limited
// field of view, only the nearest ball, noise). Plain values shared by everyone who sets them: the
// session handshake when a robot is added, the control API and doppel-ctl while it runs, and the
// publisher in doppel that applies them. Checked by the publisher; a bad value is refused naming
// its field, never clamped.

#include <cstdint>

namespace doppel::contract {

struct WorldModelSettings {
  bool enabled = true;
  double rate_hz = 30.0;             // messages per second of simulation time, (0, 1000]
  double fov_deg = 0.0;              // horizontal field of view centred on the head camera's optical
                                     // axis (the robot's heading without a camera); 0 = all around,
                                     // otherwise (0, 180)
  double max_range_m = 0.0;          // objects farther away are not seen; 0 = no limit
  bool nearest_ball_only = false;    // of several balls, report only the nearest one seen
  double position_sigma_m = 0.0;     // Gaussian noise on every seen object's position, >= 0
  double angle_sigma_rad = 0.0;      // Gaussian noise on headings (own pose, robots), >= 0
  double dropout = 0.0;              // probability that a seen object is missing from a message, [0, 1)
  double latency_s = 0.0;            // a message describes the world this long ago, [0, 1]
  uint64_t seed = 0;                 // noise sequence
};

}  // namespace doppel::contract
