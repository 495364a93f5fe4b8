#include "camera/noise.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace doppel::camera {
namespace {

// SplitMix64: a counter-based generator, so row and frame select the stream without shared state.
inline uint64_t splitmix(uint64_t& state) noexcept {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

inline double uniform01(uint64_t& state) noexcept {
  return static_cast<double>(splitmix(state) >> 11) * (1.0 / 9007199254740992.0);
}

// Standard normal variate by Box-Muller (one of the pair is used: simpler, still deterministic).
inline double normal(uint64_t& state) noexcept {
  const double u1 = std::max(uniform01(state), 1e-300);
  const double u2 = uniform01(state);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(6.283185307179586 * u2);
}

struct Range {
  const char* field;
  double NoiseConfig::*member;
  double lo;
  double hi;
};

constexpr Range kRanges[] = {
    {"gaussian_sigma", &NoiseConfig::gaussian_sigma, 0.0, 255.0},
    {"shot_noise_gain", &NoiseConfig::shot_noise_gain, 0.0, 255.0},
    {"salt_pepper_fraction", &NoiseConfig::salt_pepper_fraction, 0.0, 1.0},
    {"vignetting", &NoiseConfig::vignetting, 0.0, 1.0},
    {"wb_red_gain", &NoiseConfig::wb_red_gain, 1e-3, 100.0},
    {"wb_green_gain", &NoiseConfig::wb_green_gain, 1e-3, 100.0},
    {"wb_blue_gain", &NoiseConfig::wb_blue_gain, 1e-3, 100.0},
};

std::string number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

}  // namespace

bool NoiseConfig::active() const noexcept {
  return gaussian_sigma > 0.0 || shot_noise_gain > 0.0 || salt_pepper_fraction > 0.0 || vignetting > 0.0 ||
         wb_red_gain != 1.0 || wb_green_gain != 1.0 || wb_blue_gain != 1.0;
}

std::string_view invalid_noise_field(const NoiseConfig& c) noexcept {
  for (const Range& r : kRanges) {
    const double v = c.*r.member;
    if (!(v >= r.lo && v <= r.hi)) return r.field;
  }
  return {};
}

void validate(const NoiseConfig& c) {
  for (const Range& r : kRanges) {
    const double v = c.*r.member;
    if (!(v >= r.lo && v <= r.hi)) {
      throw std::invalid_argument(std::string("NoiseConfig.") + r.field + " must lie in [" + number(r.lo) + ", " +
                                  number(r.hi) + "], got " + number(v));
    }
  }
}

std::string describe(const NoiseConfig& c) {
  if (!c.active()) return "off";
  std::string out;
  auto add = [&out](const std::string& part) { out += (out.empty() ? "" : ", ") + part; };
  if (c.gaussian_sigma > 0.0) add("gaussian " + number(c.gaussian_sigma));
  if (c.shot_noise_gain > 0.0) add("shot " + number(c.shot_noise_gain));
  if (c.salt_pepper_fraction > 0.0) add("salt-pepper " + number(c.salt_pepper_fraction));
  if (c.vignetting > 0.0) add("vignetting " + number(c.vignetting));
  if (c.wb_red_gain != 1.0 || c.wb_green_gain != 1.0 || c.wb_blue_gain != 1.0) {
    add("white-balance " + number(c.wb_red_gain) + "," + number(c.wb_green_gain) + "," + number(c.wb_blue_gain));
  }
  add("seed " + std::to_string(c.seed));
  return out;
}

NoiseFilter::NoiseFilter(int width_px, int height_px) : width_px_(width_px), height_px_(height_px) {}

void NoiseFilter::configure(const NoiseConfig& config) {
  validate(config);
  config_ = config;
  active_ = config.active();
}

void NoiseFilter::apply_row(uint8_t* rgb, int y, uint64_t frame) const noexcept {
  if (!active_) return;
  const NoiseConfig& c = config_;
  uint64_t state = c.seed ^ (frame * 0xD1B54A32D192ED03ull) ^ (static_cast<uint64_t>(y) * 0x8CB92BA72F3D8DD7ull);
  const double gains[3] = {c.wb_red_gain, c.wb_green_gain, c.wb_blue_gain};
  const double cx = 0.5 * (width_px_ - 1);
  const double cy = 0.5 * (height_px_ - 1);
  const double inv_r2_corner = 1.0 / std::max(1.0, cx * cx + cy * cy);
  const double dy2 = (y - cy) * (y - cy);
  const bool noisy = c.gaussian_sigma > 0.0 || c.shot_noise_gain > 0.0;
  for (int x = 0; x < width_px_; ++x) {
    uint8_t* p = rgb + 3 * x;
    if (c.salt_pepper_fraction > 0.0 && uniform01(state) < c.salt_pepper_fraction) {
      const uint8_t v = (splitmix(state) & 1u) ? 255 : 0;
      p[0] = p[1] = p[2] = v;
      continue;
    }
    const double vignette = 1.0 - c.vignetting * ((x - cx) * (x - cx) + dy2) * inv_r2_corner;
    for (int ch = 0; ch < 3; ++ch) {
      double v = p[ch] * gains[ch] * vignette;
      if (noisy) {
        const double variance = c.gaussian_sigma * c.gaussian_sigma + c.shot_noise_gain * std::max(v, 0.0);
        v += std::sqrt(variance) * normal(state);
      }
      p[ch] = static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L));
    }
  }
}

}  // namespace doppel::camera
