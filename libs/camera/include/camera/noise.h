#pragma once
// Sensor imperfections applied to rendered RGB rows before they are encoded: white-balance shift,
// vignetting, shot (signal-dependent) noise, Gaussian read noise and salt-and-pepper pixels. The
// random numbers come from a counter-based generator keyed by (seed, frame, row), so a frame is the
// same whatever the thread count, and with every filter off the frame is untouched.

#include <cstdint>
#include <string>
#include <string_view>

namespace doppel::camera {

struct NoiseConfig {
  double gaussian_sigma = 0.0;        // additive read noise, standard deviation in 8-bit levels, >= 0
  double shot_noise_gain = 0.0;       // shot noise variance per level of signal (levels), >= 0
  double salt_pepper_fraction = 0.0;  // fraction of pixels forced to black or white, 0..1
  double vignetting = 0.0;            // brightness loss at the image corners, 0..1 (falls with r^2)
  double wb_red_gain = 1.0;           // white-balance gains per channel, > 0 (1 = neutral)
  double wb_green_gain = 1.0;
  double wb_blue_gain = 1.0;
  uint64_t seed = 0;                  // noise sequence; the frame number is mixed in

  // True when any filter changes pixels.
  bool active() const noexcept;
};

// Throws std::invalid_argument naming the field that is out of range and its range, e.g.
// "NoiseConfig.gaussian_sigma must lie in [0, 255], got -1". NaN is out of every range.
void validate(const NoiseConfig& config);

// The first field out of range ("gaussian_sigma", ...), or "" when `config` is valid. rt-safe, for
// settings that arrive while streaming.
std::string_view invalid_noise_field(const NoiseConfig& config) noexcept;

// One line for users: "off", or the active filters, e.g. "gaussian 2, salt-pepper 0.001, seed 7".
std::string describe(const NoiseConfig& config);

class NoiseFilter {
 public:
  NoiseFilter(int width_px, int height_px);

  // Takes effect from the next apply_row(); setup code (validates, may throw).
  void configure(const NoiseConfig& config);
  const NoiseConfig& config() const noexcept { return config_; }
  bool active() const noexcept { return active_; }

  // Applies every active filter to row `y` of frame number `frame` (`rgb`: 3 * width bytes). rt-safe.
  void apply_row(uint8_t* rgb, int y, uint64_t frame) const noexcept;

 private:
  int width_px_;
  int height_px_;
  NoiseConfig config_;
  bool active_ = false;
};

}  // namespace doppel::camera
