// doppel-camera: look at the cameras a running doppel publishes.
//   doppel-camera list                                   cameras and their formats
//   doppel-camera save [--camera NAME] --count N --out DIR  next N frames as PNG + JSON ground truth
//   doppel-camera stats [--camera NAME] [--seconds S] [--poll]  rate, drops and delivery latency
//   doppel-camera noise --camera NAME [--off] [--gaussian SIGMA] ...  change the noise while running
// Exit codes: 0 done, 1 runtime error (no RouDi, no camera, timeout), 2 usage error.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "base/monotonic_clock.h"
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
  bool help = false;
  bool verbose = false;  // --verbose: also print iceoryx's own log lines
  // noise: the options given, applied in this order on top of the current settings
  bool noise_off = false;
  std::vector<std::pair<std::string, std::string>> noise_options;  // option, value as given
};

// `text` converted by CLI11 (the tool's one number parser); a usage error naming `option` and what it
// needs otherwise.
template <typename T>
T number(const std::string& option, const std::string& text, const std::string& needs) {
  T value{};
  if (!CLI::detail::lexical_cast(text, value)) {
    throw UsageError(option + " needs " + needs + ", got '" + text + "'");
  }
  return value;
}

// A CLI11 check that the value of `option` is a number of type T for which `ok` holds.
template <typename T>
CLI::Validator number_check(const std::string& option, const std::string& needs, bool (*ok)(T)) {
  return CLI::Validator(
      [option, needs, ok](std::string& text) {
        if (!ok(number<T>(option, text, needs))) {
          throw UsageError(option + " needs " + needs + ", got '" + text + "'");
        }
        return std::string();
      },
      "");
}

bool positive(double v) { return v > 0.0; }
bool positive_integer(long v) { return v > 0; }

constexpr const char* kNoiseOptions[] = {"--gaussian", "--shot", "--salt-pepper", "--vignetting", "--white-balance",
                                         "--seed"};

Args parse(int argc, char** argv) {
  Args a;
  CLI::App app("doppel-camera");
  app.set_help_flag();  // kUsage is the help text
  app.add_flag("-h,--help", a.help);
  app.fallthrough();
  CLI::App* list = app.add_subcommand("list");
  CLI::App* save = app.add_subcommand("save");
  CLI::App* stats = app.add_subcommand("stats");
  CLI::App* noise = app.add_subcommand("noise");
  for (CLI::App* command : {save, stats, noise}) {
    command->add_option("--camera", a.camera);
  }
  for (CLI::App* command : {list, save, noise}) {
    command->add_option("--timeout", a.timeout_s)->check(number_check("--timeout", "a positive number", positive));
  }
  save->add_option("--count", a.count)->check(number_check("--count", "a positive integer", positive_integer));
  save->add_option("--out", a.out);
  stats->add_option("--seconds", a.seconds)->check(number_check("--seconds", "a positive number", positive));
  stats->add_flag("--poll", a.poll);
  for (CLI::App* command : {list, save, stats, noise}) {
    command->add_flag("--verbose", a.verbose);
  }
  noise->add_flag("--off", a.noise_off);
  for (const char* option : kNoiseOptions) {
    noise->add_option(option)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    throw UsageError(e.what());
  }
  if (a.help) return a;
  if (app.get_subcommands().empty()) throw UsageError("missing command");
  a.command = app.get_subcommands().front()->get_name();
  // The noise settings in the order given (each value converted in noise_from_args).
  std::vector<std::size_t> seen(std::size(kNoiseOptions), 0);
  for (const CLI::Option* option : noise->parse_order()) {
    const auto it = std::find(std::begin(kNoiseOptions), std::end(kNoiseOptions), option->get_name());
    if (it == std::end(kNoiseOptions)) continue;
    std::size_t& k = seen[static_cast<std::size_t>(it - std::begin(kNoiseOptions))];
    a.noise_options.emplace_back(*it, option->results().at(k++));
  }
  if (a.command == "save" && (a.count <= 0 || a.out.empty())) throw UsageError("save needs --count N and --out DIR");
  if (a.command == "noise" && a.camera.empty()) throw UsageError("noise needs --camera NAME");
  if (a.command == "noise" && !a.noise_off && a.noise_options.empty()) {
    throw UsageError("noise needs --off or at least one setting");
  }
  return a;
}

std::string pick_camera(const Args& a) {
  if (!a.camera.empty()) return a.camera;
  const auto cameras = list_cameras(std::min(a.timeout_s, 3.0));
  if (cameras.empty()) throw std::runtime_error("no camera is published on this machine");
  return cameras.front().name;
}

// The camera's current settings with the command line's changes on top. Throws UsageError naming
// the option when a value does not parse or is out of range.
NoiseConfig noise_from_args(const Args& a, const NoiseConfig& current) {
  NoiseConfig noise = a.noise_off ? NoiseConfig{} : current;
  if (a.noise_off) noise.seed = current.seed;
  for (const auto& [flag, text] : a.noise_options) {
    if (flag == "--gaussian") {
      noise.gaussian_sigma = number<double>(flag, text, "a number");
    } else if (flag == "--shot") {
      noise.shot_noise_gain = number<double>(flag, text, "a number");
    } else if (flag == "--salt-pepper") {
      noise.salt_pepper_fraction = number<double>(flag, text, "a number");
    } else if (flag == "--vignetting") {
      noise.vignetting = number<double>(flag, text, "a number");
    } else if (flag == "--white-balance") {
      const std::vector<std::string> gains = CLI::detail::split(text, ',');
      if (gains.size() != 3) {
        throw UsageError("--white-balance needs three gains R,G,B (1 = neutral), got '" + text + "'");
      }
      noise.wb_red_gain = number<double>(flag, gains[0], "a number");
      noise.wb_green_gain = number<double>(flag, gains[1], "a number");
      noise.wb_blue_gain = number<double>(flag, gains[2], "a number");
    } else if (flag == "--seed") {
      if (!text.empty() && text[0] == '-') {  // strtoull, under CLI11's conversion, wraps negatives
        throw UsageError("--seed needs a non-negative integer, got '" + text + "'");
      }
      noise.seed = number<uint64_t>(flag, text, "a non-negative integer");
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
    const std::string json = frame_ground_truth_json(h, frame->annotations());
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
  const int64_t start = doppel::monotonic_now_ns();
  const int64_t end = start + static_cast<int64_t>(a.seconds * 1e9);
  int64_t first_ns = 0;
  int64_t last_ns = 0;
  while (doppel::monotonic_now_ns() < end) {
    std::optional<Frame> frame = a.poll ? sub.try_take() : sub.wait_take(0.2);
    if (!frame) continue;
    const int64_t now = doppel::monotonic_now_ns();
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
    if (a.help) {
      std::cout << kUsage;
      return 0;
    }
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
