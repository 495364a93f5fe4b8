// doppel-camera: look at the cameras a running doppel publishes.
//   doppel-camera list                                   cameras and their formats
//   doppel-camera save [--camera NAME] --count N --out DIR  next N frames as PNG + JSON ground truth
//   doppel-camera stats [--camera NAME] [--seconds S] [--poll]  rate, drops and delivery latency
//   doppel-camera noise --camera NAME [--off] [--gaussian SIGMA] ...  change the noise while running
// Exit codes: 0 done, 1 runtime error (no RouDi, no camera, timeout), 2 usage error.

#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "camera/client.h"
#include "camera/image_io.h"

namespace {

using namespace doppel::camera;

struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

constexpr const char* kUsage =
    "usage: doppel-camera list [--timeout S]\n"
    "       doppel-camera save [--camera NAME] --count N --out DIR [--timeout S]\n"
    "       doppel-camera stats [--camera NAME] [--seconds S] [--poll]\n"
    "       doppel-camera noise --camera NAME [--off] [--gaussian SIGMA] [--shot GAIN]\n"
    "                           [--salt-pepper FRACTION] [--vignetting V] [--white-balance R,G,B]\n"
    "                           [--seed N] [--timeout S]\n"
    "  Every command takes --verbose: also print iceoryx's own log lines.\n"
    "  noise: settings not given keep their current values; --off first turns every filter off.\n"
    "  Ranges: gaussian 0..255 (levels), shot 0..255 (variance per level), salt-pepper 0..1,\n"
    "  vignetting 0..1, white-balance gains 0.001..100 (1 = neutral).\n";

struct Args {
  std::string command;
  std::string camera;
  std::string out;
  long count = -1;
  double timeout_s = 10.0;
  double seconds = 5.0;
  bool poll = false;
  bool verbose = false;  // --verbose: also print iceoryx's own log lines
  // noise: the options given, applied in this order on top of the current settings
  bool noise_off = false;
  std::vector<std::pair<std::string, std::string>> noise_options;  // flag, value
};

constexpr const char* kNoiseFlags[] = {"--gaussian", "--shot", "--salt-pepper", "--vignetting", "--white-balance",
                                       "--seed"};

double parse_number(const std::string& flag, const std::string& value) {
  try {
    size_t used = 0;
    const double v = std::stod(value, &used);
    if (used != value.size() || !(v > 0.0)) throw std::invalid_argument("bad");
    return v;
  } catch (const std::exception&) {
    throw UsageError(flag + " needs a positive number, got '" + value + "'");
  }
}

Args parse(int argc, char** argv) {
  if (argc < 2) throw UsageError("missing command");
  Args a;
  a.command = argv[1];
  if (a.command != "list" && a.command != "save" && a.command != "stats" && a.command != "noise") {
    throw UsageError("unknown command '" + a.command + "'");
  }
  for (int i = 2; i < argc; ++i) {
    const std::string flag = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw UsageError(flag + " needs a value");
      return argv[++i];
    };
    if (flag == "--camera") {
      a.camera = value();
    } else if (flag == "--out") {
      a.out = value();
    } else if (flag == "--count") {
      a.count = static_cast<long>(parse_number(flag, value()));
    } else if (flag == "--timeout") {
      a.timeout_s = parse_number(flag, value());
    } else if (flag == "--seconds") {
      a.seconds = parse_number(flag, value());
    } else if (flag == "--poll") {
      a.poll = true;
    } else if (flag == "--verbose") {
      a.verbose = true;
    } else if (a.command == "noise" && flag == "--off") {
      a.noise_off = true;
    } else if (a.command == "noise" &&
               std::find(std::begin(kNoiseFlags), std::end(kNoiseFlags), flag) != std::end(kNoiseFlags)) {
      a.noise_options.emplace_back(flag, value());
    } else {
      throw UsageError("unknown option '" + flag + "'");
    }
  }
  if (a.command == "save" && (a.count <= 0 || a.out.empty())) throw UsageError("save needs --count N and --out DIR");
  if (a.command == "noise" && a.camera.empty()) throw UsageError("noise needs --camera NAME");
  if (a.command == "noise" && !a.noise_off && a.noise_options.empty()) {
    throw UsageError("noise needs --off or at least one setting");
  }
  return a;
}

int64_t mono_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

std::string pick_camera(const Args& a) {
  if (!a.camera.empty()) return a.camera;
  const auto cameras = list_cameras(std::min(a.timeout_s, 3.0));
  if (cameras.empty()) throw std::runtime_error("no camera is published on this machine");
  return cameras.front().name;
}

// A finite or non-finite number as written (range checks follow in validate()).
double parse_double(const std::string& flag, const std::string& text) {
  try {
    size_t used = 0;
    const double v = std::stod(text, &used);
    if (used == text.size()) return v;
  } catch (const std::exception&) {
  }
  throw UsageError(flag + " needs a number, got '" + text + "'");
}

// The camera's current settings with the command line's changes on top. Throws UsageError naming
// the option when a value does not parse or is out of range.
NoiseConfig noise_from_args(const Args& a, const NoiseConfig& current) {
  NoiseConfig noise = a.noise_off ? NoiseConfig{} : current;
  if (a.noise_off) noise.seed = current.seed;
  for (const auto& [flag, text] : a.noise_options) {
    if (flag == "--gaussian") {
      noise.gaussian_sigma = parse_double(flag, text);
    } else if (flag == "--shot") {
      noise.shot_noise_gain = parse_double(flag, text);
    } else if (flag == "--salt-pepper") {
      noise.salt_pepper_fraction = parse_double(flag, text);
    } else if (flag == "--vignetting") {
      noise.vignetting = parse_double(flag, text);
    } else if (flag == "--white-balance") {
      const size_t c1 = text.find(',');
      const size_t c2 = c1 == std::string::npos ? c1 : text.find(',', c1 + 1);
      if (c2 == std::string::npos || text.find(',', c2 + 1) != std::string::npos) {
        throw UsageError("--white-balance needs three gains R,G,B (1 = neutral), got '" + text + "'");
      }
      noise.wb_red_gain = parse_double(flag, text.substr(0, c1));
      noise.wb_green_gain = parse_double(flag, text.substr(c1 + 1, c2 - c1 - 1));
      noise.wb_blue_gain = parse_double(flag, text.substr(c2 + 1));
    } else if (flag == "--seed") {
      size_t used = 0;
      unsigned long long seed = 0;
      try {
        seed = std::stoull(text, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != text.size() || text.empty() || text[0] == '-') {
        throw UsageError("--seed needs a non-negative integer, got '" + text + "'");
      }
      noise.seed = seed;
    }
    try {
      validate(noise);
    } catch (const std::invalid_argument& e) {
      throw UsageError(flag + " " + text + ": " + e.what());
    }
  }
  return noise;
}

int cmd_noise(const Args& a) {
  const auto cameras = list_cameras(std::min(a.timeout_s, 3.0));
  const auto it = std::find_if(cameras.begin(), cameras.end(),
                               [&](const CameraInfo& c) { return a.camera == c.name; });
  if (it == cameras.end()) throw std::runtime_error("no camera '" + a.camera + "' is published on this machine");
  const NoiseConfig noise = noise_from_args(a, it->noise);
  const CameraInfo confirmed = set_camera_noise(a.camera, noise, a.timeout_s);
  std::cout << "camera " << confirmed.name << ": noise " << describe(confirmed.noise) << " from frame "
            << confirmed.noise_from_sequence << "\n";
  return 0;
}

int cmd_list(const Args& a) {
  const auto cameras = list_cameras(std::min(a.timeout_s, 3.0));
  if (cameras.empty()) {
    std::cout << "no cameras\n";
    return 0;
  }
  std::printf("%-20s %-11s %-11s %6s  %-14s %-12s %-8s %s\n", "camera", "size", "format", "fps", "lens", "body",
              "pid", "noise");
  for (const CameraInfo& c : cameras) {
    const std::string size = std::to_string(c.width_px) + "x" + std::to_string(c.height_px);
    const std::string format(to_string(static_cast<PixelFormat>(c.format)));
    const std::string lens(to_string(c.lens.model));
    std::printf("%-20s %-11s %-11s %6.1f  %-14s %-12s %-8d %s\n", c.name, size.c_str(), format.c_str(), c.fps,
                lens.c_str(), c.body[0] ? c.body : "(world)", c.pid, describe(c.noise).c_str());
  }
  return 0;
}

std::string header_json(const FrameHeader& h) {
  std::ostringstream o;
  o.precision(9);
  o << "{\"camera\": \"" << h.camera_name << "\", \"sequence\": " << h.sequence << ", \"sim_time_ns\": " << h.sim_time_ns
    << ", \"exposure_time_ns\": " << h.exposure_time_ns << ", \"wall_time_ns\": " << h.wall_time_ns
    << ", \"format\": \"" << to_string(static_cast<PixelFormat>(h.format)) << "\", \"width_px\": " << h.width_px
    << ", \"height_px\": " << h.height_px << ", \"camera_position_w_m\": [" << h.position_w_m[0] << ", "
    << h.position_w_m[1] << ", " << h.position_w_m[2] << "], \"camera_orientation_w_wxyz\": [" << h.orientation_w[0]
    << ", " << h.orientation_w[1] << ", " << h.orientation_w[2] << ", " << h.orientation_w[3]
    << "], \"lens\": {\"model\": \"" << to_string(h.lens.model) << "\", \"fx_px\": " << h.lens.fx_px
    << ", \"fy_px\": " << h.lens.fy_px << ", \"cx_px\": " << h.lens.cx_px << ", \"cy_px\": " << h.lens.cy_px
    << ", \"k1\": " << h.lens.k1 << ", \"k2\": " << h.lens.k2 << ", \"k3\": " << h.lens.k3 << ", \"p1\": " << h.lens.p1
    << ", \"p2\": " << h.lens.p2 << ", \"fov_deg\": " << h.lens.fov_deg << "}, \"frames_dropped\": " << h.frames_dropped
    << ",\n \"annotations\": ";
  return o.str();
}

int cmd_save(const Args& a) {
  const std::string camera = pick_camera(a);
  std::filesystem::create_directories(a.out);
  std::string stem = camera;
  std::replace(stem.begin(), stem.end(), '/', '_');
  FrameSubscriber sub(camera);
  std::vector<uint8_t> rgb;
  for (long saved = 0; saved < a.count;) {
    auto frame = sub.wait_take(a.timeout_s);
    if (!frame) {
      std::cerr << "doppel-camera: no frame from '" << camera << "' within " << a.timeout_s << " s\n";
      return 1;
    }
    const FrameHeader& h = frame->header();
    rgb.resize(3 * static_cast<size_t>(h.width_px) * h.height_px);
    decode_to_rgb(static_cast<PixelFormat>(h.format), frame->pixels(), h.width_px, h.height_px, rgb.data());
    char seq[32];
    std::snprintf(seq, sizeof(seq), "%08llu", static_cast<unsigned long long>(h.sequence));
    const std::string base = (std::filesystem::path(a.out) / (stem + "_" + seq)).string();
    std::string json = header_json(h);
    json += frame->annotations() ? annotations_to_json(*frame->annotations()) : std::string("[]\n");
    json += "}\n";
    frame->release();
    write_png_rgb(base + ".png", rgb.data(), static_cast<int>(rgb.size() / 3 / std::max(1, h.height_px)),
                  h.height_px);
    std::ofstream(base + ".json") << json;
    ++saved;
    std::cout << base << ".png\n" << std::flush;
  }
  return 0;
}

int cmd_stats(const Args& a) {
  const std::string camera = pick_camera(a);
  FrameSubscriber sub(camera);
  std::vector<double> latency_us;
  uint64_t first_dropped = 0;
  uint64_t last_dropped = 0;
  bool any = false;
  const int64_t start = mono_ns();
  const int64_t end = start + static_cast<int64_t>(a.seconds * 1e9);
  int64_t first_ns = 0;
  int64_t last_ns = 0;
  while (mono_ns() < end) {
    std::optional<Frame> frame = a.poll ? sub.try_take() : sub.wait_take(0.2);
    if (!frame) continue;
    const int64_t now = mono_ns();
    latency_us.push_back(1e-3 * static_cast<double>(now - frame->header().publish_mono_ns));
    if (!any) {
      first_dropped = frame->header().frames_dropped;
      first_ns = now;
      any = true;
    }
    last_dropped = frame->header().frames_dropped;
    last_ns = now;
  }
  const SubscriberStats s = sub.stats();
  if (latency_us.empty()) {
    std::cerr << "doppel-camera: no frame from '" << camera << "' within " << a.seconds << " s\n";
    return 1;
  }
  std::sort(latency_us.begin(), latency_us.end());
  auto pct = [&](double p) { return latency_us[static_cast<size_t>(p * (latency_us.size() - 1))]; };
  const double span_s = 1e-9 * static_cast<double>(last_ns - first_ns);
  std::printf("camera %s (%s)\n", camera.c_str(), a.poll ? "busy polling" : "WaitSet");
  std::printf("frames %llu  rate %.2f /s  missed %llu  publisher drops %llu\n",
              static_cast<unsigned long long>(s.received), span_s > 0 ? (s.received - 1) / span_s : 0.0,
              static_cast<unsigned long long>(s.missed), static_cast<unsigned long long>(last_dropped - first_dropped));
  std::printf("latency publish->held  median %.1f us  p99 %.1f us  max %.1f us\n", pct(0.5), pct(0.99),
              latency_us.back());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args a = parse(argc, argv);
    if (a.command == "noise") (void)noise_from_args(a, NoiseConfig{});  // bad values: usage error, before any RouDi
    connect_client("doppel-camera", a.verbose);
    if (a.command == "list") return cmd_list(a);
    if (a.command == "save") return cmd_save(a);
    if (a.command == "noise") return cmd_noise(a);
    return cmd_stats(a);
  } catch (const UsageError& e) {
    std::cerr << "doppel-camera: " << e.what() << "\n" << kUsage;
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "doppel-camera: " << e.what() << "\n";
    return 1;
  }
}
