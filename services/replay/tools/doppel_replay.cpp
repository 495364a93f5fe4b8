// doppel-replay: a recording of `doppel --record` served to the web viewer (play, pause, scrub,
// speed), or with --bus its driver's bytes written again to a doppel's bus (docs/replay.md).
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "base/command_line.h"
#include "bus/link_directory.h"
#include "contract/access_token.h"
#include "control/access.h"
#include "control/http_api.h"
#include "replay/bus_replay.h"
#include "replay/recording.h"
#include "replay/replay_control.h"

namespace {

using namespace doppel;

struct Options {
  std::string file;
  bool info = false;
  bool bus_mode = false;
  uint16_t viewer_port = control::kDefaultPort;
  std::string viewer_address = "127.0.0.1";
  std::string viewer_dir;
  std::string link_dir = bus::default_link_dir();  // where the access token goes (token-PORT)
  bool token = true;
  double speed = 1.0;
  bool paused = false;
  double start_s = -1.0;
  std::string port;
  uint32_t robot = 0, bus = 0;
  bool robot_given = false;
  bool start_doppel = false;
  std::string doppel = DOPPEL_EXECUTABLE;
  std::string doppel_args;
  uint32_t timeout_ms = 100;
  std::size_t report_lines = 50;
  bool every = false;
};

int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

long peak_rss_kib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

long rss_kib() {
  long pages = 0, resident = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return resident * (sysconf(_SC_PAGESIZE) / 1024);
}

int info(const Options& options) {
  const int64_t t0 = now_ms();
  const replay::Recording recording(options.file);
  const int64_t load_ms = now_ms() - t0;
  const auto& run = recording.run();
  std::printf("%s: %.3f s recorded (world from %.3f s)\n", options.file.c_str(), recording.end_ns() * 1e-9,
              recording.start_ns() * 1e-9);
  if (!run.doppel_version().empty()) std::printf("doppel %s: %s\n", run.doppel_version().c_str(), run.command_line().c_str());
  for (const auto& bus : run.buses()) {
    std::printf("robot %u '%s' bus %u (%s): %zu devices, %u baud\n", bus.robot(), bus.robot_name().c_str(), bus.bus(),
                bus.link().c_str(), static_cast<std::size_t>(bus.devices_size()), bus.configured_baud_bps());
  }
  for (const auto& [topic, n] : recording.topic_counts()) std::printf("  %-44s %10llu messages\n", topic.c_str(), static_cast<unsigned long long>(n));
  if (recording.summary()) {
    std::printf("recorder: %llu messages, %llu dropped, %llu bus events dropped, %llu world states dropped\n",
                static_cast<unsigned long long>(recording.summary()->messages()),
                static_cast<unsigned long long>(recording.summary()->dropped_messages()),
                static_cast<unsigned long long>(recording.summary()->dropped_bus_events()),
                static_cast<unsigned long long>(recording.summary()->dropped_world_states()));
  }
  if (!recording.recovery_note().empty()) std::printf("note: %s\n", recording.recovery_note().c_str());
  for (const std::string& warning : recording.warnings()) std::printf("warning: %s\n", warning.c_str());
  auto mib = [](std::size_t bytes) { return static_cast<double>(bytes) / (1024.0 * 1024.0); };
  std::size_t cameras = 0;
  for (const auto& [name, track] : recording.cameras()) cameras += track.held_bytes();
  std::printf("loaded in %lld ms; held for replay: %.1f MiB (world %.1f, scene poses %.1f, servo tables %.1f, cameras %.1f)\n",
              static_cast<long long>(load_ms), mib(recording.held_bytes()), mib(recording.world().held_bytes()),
              mib(recording.scene_poses().held_bytes()), mib(recording.servos().held_bytes()), mib(cameras));
  std::printf("resident memory now %.1f MiB, at most %.1f MiB while loading\n", static_cast<double>(rss_kib()) / 1024.0,
              static_cast<double>(peak_rss_kib()) / 1024.0);
  return 0;
}

volatile sig_atomic_t g_stop = 0;

int serve(const Options& options) {
  const replay::Recording recording(options.file);
  for (const std::string& warning : recording.warnings()) std::fprintf(stderr, "doppel-replay: warning: %s\n", warning.c_str());
  if (!recording.recovery_note().empty()) std::fprintf(stderr, "doppel-replay: %s\n", recording.recovery_note().c_str());
  replay::ReplayControl control(recording);
  contract::ReplayChange change;
  change.speed = options.speed;
  if (options.start_s >= 0.0) {
    if (options.start_s > recording.end_ns() * 1e-9) {
      throw std::runtime_error("--start " + std::to_string(options.start_s) + " s is past the end of the recording (" +
                               std::to_string(recording.end_ns() * 1e-9) + " s)");
    }
    change.position_s = std::max(options.start_s, recording.start_ns() * 1e-9);
  }
  change.playing = !options.paused;
  if (const contract::Outcome started = control.change_replay(change); !started.ok()) {
    throw std::runtime_error(started.error().message);
  }
  control::StaticFiles files = control::default_static_files();
  if (!options.viewer_dir.empty()) files.viewer_dir = options.viewer_dir;
  // The same access rules as doppel's (control/access.h, docs/security.md): a recording can hold
  // camera images and everything the robots did.
  std::string token;
  if (options.token) {
    token = contract::new_access_token();
  } else {
    std::fprintf(stderr, "doppel-replay: warning: --no-token: every local user and program can use the viewer's API "
                         "(docs/security.md)\n");
  }
  control::HttpApi api(control.facets(), options.viewer_address, options.viewer_port, files, token);
  std::unique_ptr<bus::LinkDirectory> link_dir;
  std::unique_ptr<contract::TokenFile> token_file;
  if (!token.empty()) {
    link_dir = std::make_unique<bus::LinkDirectory>(options.link_dir, false, std::cerr);
    token_file = std::make_unique<contract::TokenFile>(contract::token_file_path(link_dir->path(), api.port()), token);
  }
  api.start();
  std::printf("doppel-replay: %s, %.3f s; viewer on http://%s:%u/%s (Ctrl-C stops)\n", options.file.c_str(),
              recording.end_ns() * 1e-9, api.address().c_str(), api.port(), token.empty() ? "" : ("?token=" + token).c_str());
  if (token_file != nullptr) std::printf("doppel-replay: access token in %s (doppel-ctl reads it)\n", token_file->path().c_str());
  std::fflush(stdout);
  signal(SIGINT, [](int) { g_stop = 1; });
  signal(SIGTERM, [](int) { g_stop = 1; });
  while (!g_stop) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  api.stop();
  return 0;
}

// A doppel started for the replay, stopped (SIGTERM) when this ends.
class StartedDoppel {
 public:
  StartedDoppel(const Options& options, const replay::RecordedBus& bus, const recording::RunInfo& run) {
    const std::string& timing = run.timing_mode();
    char pattern[] = "/tmp/doppel-replay-XXXXXX";
    if (mkdtemp(pattern) == nullptr) throw std::runtime_error("cannot make a temporary folder for --start-doppel");
    dir_ = pattern;
    std::vector<std::string> args = {options.doppel, "--no-viewer", "--no-camera", "--fresh", "--link-dir", dir_ + "/links",
                                     "--state-dir", dir_ + "/state"};
    if (!bus.info->robot_name().empty()) args.insert(args.end(), {"--robot", bus.info->robot_name()});
    if (timing == "wire" || timing == "fast") args.insert(args.end(), {"--timing", timing});
    if (run.physics_engine() == "ode" || run.physics_engine() == "bullet") args.insert(args.end(), {"--physics", run.physics_engine()});
    if (bus.info->adapter_latency_ms() != 0) args.insert(args.end(), {"--latency-timer", std::to_string(bus.info->adapter_latency_ms())});
    std::string extra = options.doppel_args;
    for (std::size_t at = 0; at < extra.size();) {
      const std::size_t space = extra.find(' ', at);
      const std::string word = extra.substr(at, space == std::string::npos ? std::string::npos : space - at);
      if (!word.empty()) args.push_back(word);
      at = space == std::string::npos ? extra.size() : space + 1;
    }
    link_ = dir_ + "/links/" + std::filesystem::path(bus.info->link()).filename().string();
    std::string command;
    for (const std::string& a : args) command += (command.empty() ? "" : " ") + a;
    std::fprintf(stderr, "doppel-replay: starting %s\n", command.c_str());
    const std::string log = dir_ + "/doppel.txt";
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      std::freopen(log.c_str(), "w", stdout);
      dup2(fileno(stdout), 2);
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      execv(argv[0], argv.data());
      std::perror("exec doppel");
      _exit(127);
    }
    // Ready once it says it runs (every port served), not when the link appears: a bus answering
    // its first packets while the rest still starts would put a slip into the replay's schedule.
    const int64_t deadline = now_ms() + 60'000;
    auto ready = [&] {
      std::FILE* f = std::fopen(log.c_str(), "r");
      if (f == nullptr) return false;
      std::string text(1 << 16, '\0');
      text.resize(std::fread(text.data(), 1, text.size(), f));
      std::fclose(f);
      return text.find("running until") != std::string::npos && std::filesystem::exists(link_);
    };
    while (!ready()) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        throw std::runtime_error("doppel exited before its bus " + link_ + " appeared; its output is in " + log);
      }
      if (now_ms() > deadline) throw std::runtime_error("doppel did not make " + link_ + " within 60 s; see " + log);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~StartedDoppel() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  const std::string& link() const { return link_; }

 private:
  pid_t pid_ = -1;
  std::string dir_, link_;
};

int replay_bus(const Options& options) {
  Options o = options;
  if (!o.robot_given) {
    const auto buses = replay::recorded_buses(o.file);
    if (buses.empty()) throw std::runtime_error(o.file + " has no bus transactions (topics /doppel/bus/R/B/transactions)");
    if (buses.size() > 1) {
      std::string list;
      for (const auto& [r, b] : buses) list += " --robot " + std::to_string(r) + " --bus " + std::to_string(b) + ";";
      std::fprintf(stderr, "doppel-replay: %zu buses recorded, replaying the first (others:%s)\n", buses.size(), list.c_str());
    }
    o.robot = buses.front().first;
    o.bus = buses.front().second;
  }
  const replay::RecordedBus recorded = replay::load_bus(o.file, o.robot, o.bus);
  if (recorded.transactions.empty()) {
    throw std::runtime_error(o.file + " has no transactions of robot " + std::to_string(o.robot) + " bus " + std::to_string(o.bus));
  }
  if (recorded.sequence_gaps > 0) {
    std::fprintf(stderr, "doppel-replay: the recording lost %llu transactions of this bus (sequence gaps): they are not replayed\n",
                 static_cast<unsigned long long>(recorded.sequence_gaps));
  }
  std::unique_ptr<StartedDoppel> started;
  std::string link = o.port;
  if (o.start_doppel) {
    if (!recorded.info) throw std::runtime_error(o.file + " has no /doppel/run bus list: --start-doppel cannot tell which robot; start doppel yourself and give --port");
    replay::Recording run_only(o.file);
    started = std::make_unique<StartedDoppel>(o, recorded, run_only.run());
    link = started->link();
  }
  if (link.empty()) {
    throw std::runtime_error("give --port LINK (the bus link of a doppel started with the recording's robot) or --start-doppel");
  }
  const uint32_t baud = recorded.transactions.front().baud_bps() != 0 ? recorded.transactions.front().baud_bps()
                        : recorded.info ? recorded.info->configured_baud_bps() : 1'000'000;
  const int fd = replay::open_bus_port(link, baud);
  replay::RegisterNames names = recorded.info ? replay::RegisterNames(*recorded.info) : replay::RegisterNames();
  replay::BusReplayOptions replay_options;
  replay_options.speed = o.speed;
  replay_options.reply_timeout_ns = static_cast<int64_t>(o.timeout_ms) * 1'000'000;
  replay::BusReplayer replayer(fd, names, replay_options);
  const bool tty = isatty(2) != 0;
  int64_t last_progress = 0;
  const auto results = replayer.run(recorded.transactions, [&](std::size_t done, std::size_t total) {
    if (!tty) return;
    const int64_t now = now_ms();
    if (now - last_progress < 200 && done != total) return;
    last_progress = now;
    std::fprintf(stderr, "\r%zu / %zu transactions", done, total);
    if (done == total) std::fprintf(stderr, "\n");
  });
  close(fd);
  const replay::BusReplaySummary summary = replay::summarize(results);
  std::printf("robot %u bus %u of %s against %s\n%s", o.robot, o.bus, o.file.c_str(), link.c_str(),
              replay::format_report(results, summary, o.report_lines, o.every).c_str());
  const auto differed = summary.verdicts.find(replay::Verdict::kDiffered);
  const auto missing = summary.verdicts.find(replay::Verdict::kMissing);
  const bool clean = (differed == summary.verdicts.end() || differed->second == 0) &&
                     (missing == summary.verdicts.end() || missing->second == 0);
  return clean ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  CLI::App app(
      "doppel-replay: serve a recording of doppel --record to the web viewer (play, pause, scrub, speed), or with --bus "
      "write its driver's bytes to a doppel's bus again and compare the answers (docs/replay.md)",
      "doppel-replay");
  app.add_option("FILE", options.file, "the recording (doppel --record FILE.mcap)");
  app.add_flag("--info", options.info, "print what the recording holds, how long it took to load and the memory it takes, and exit");
  app.add_option("--viewer", options.viewer_port, "port of the viewer and control API (0: any free port)")
      ->capture_default_str()->transform(number_in<uint16_t>(0, 65535));
  app.add_option("--viewer-address", options.viewer_address, "address to serve on")->capture_default_str();
  app.add_option("--viewer-dir", options.viewer_dir, "the viewer's page from this folder");
  app.add_option("--link-dir", options.link_dir, "where the run's access token goes (token-PORT; as doppel's --link-dir)")
      ->capture_default_str();
  app.add_flag("--no-token{false}", options.token, "serve the API without an access token (docs/security.md)");
  app.add_option("--speed", options.speed, "playback speed (viewer: 0.1..10; --bus: the recorded pace times this)")
      ->capture_default_str()->transform(number_in<double>(contract::kMinReplaySpeed, contract::kMaxReplaySpeed));
  app.add_option("--start", options.start_s, "start at this many seconds into the recording")->transform(number_in<double>(0.0, 1e9));
  app.add_flag("--paused", options.paused, "start paused");
  // --bus alone switches the mode; --bus B (a number) also names the bus. "--bus FILE" is the mode and the file.
  std::string bus_value;
  app.add_option("--bus", bus_value, "[B] replay the driver's bytes of bus B (default: the first recorded) against a doppel "
                                     "and compare its answers")
      ->expected(0, 1);
  app.add_option("--port", options.port, "--bus: the bus link of a doppel started with the recording's robot");
  auto* robot = app.add_option("--robot", options.robot, "--bus: the robot's index in the recording (default: the first bus recorded; with --bus B)")
      ->transform(number_in<uint32_t>(0, 1000));
  app.add_flag("--start-doppel", options.start_doppel, "--bus: start a fresh doppel with the recording's robot and timing (no viewer, no camera)");
  app.add_option("--doppel", options.doppel, "--start-doppel: the doppel executable")->capture_default_str();
  app.add_option("--doppel-args", options.doppel_args, "--start-doppel: more doppel options, space separated");
  app.add_option("--timeout-ms", options.timeout_ms, "--bus: how long beyond the recorded reply time to wait for a status")
      ->capture_default_str()->transform(number_in<uint32_t>(1, 10'000));
  app.add_option("--report-lines", options.report_lines, "--bus: most transactions listed")->capture_default_str();
  app.add_flag("--every", options.every, "--bus: one line per transaction, matched ones included");
  CLI11_PARSE(app, argc, argv);
  options.bus_mode = app.count("--bus") > 0;
  if (!bus_value.empty()) {
    if (bus_value.find_first_not_of("0123456789") == std::string::npos && bus_value.size() < 6) {
      options.bus = static_cast<uint32_t>(std::stoul(bus_value));
    } else if (options.file.empty()) {
      options.file = bus_value;
    } else {
      std::fprintf(stderr, "--bus: '%s' is not a bus index\n", bus_value.c_str());
      return 2;
    }
  }
  if (options.file.empty()) {
    std::fprintf(stderr, "FILE is required (a recording of doppel --record FILE.mcap); --help lists the options\n");
    return 2;
  }
  if (!std::filesystem::is_regular_file(options.file)) {
    std::fprintf(stderr, "doppel-replay: %s: no such file\n", options.file.c_str());
    return 1;
  }
  options.robot_given = robot->count() > 0 || (!bus_value.empty() && options.bus_mode && bus_value != options.file);
  try {
    if (options.info) return info(options);
    if (options.bus_mode) return replay_bus(options);
    return serve(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "doppel-replay: %s\n", e.what());
    return 1;
  }
}
