// viewer_load: does an open web viewer slow doppel's bus or simulation threads? One doppel run
// (default robot, physics on, viewer on a free port); phases rotate between "closed" (nobody
// reads the viewer's API), "polled" (a thread of this tool polls the API as the page does:
// /api/scene at 20 Hz, /api/state at 10 Hz, /api/buses at 2 Hz, the first robot camera's still
// /api/camera/NAME about 3 times a second: doppel's own serving cost) and
// "open" (headless Chromium shows the viewer page, which polls so and renders with three.js in
// software (SwiftShader) on the same cores: the page's cost to a machine without a GPU).
// In every phase the client reads servo 1's Present Position (READ 2 B) back to back and times
// each round trip; the simulation's missed 1 ms ticks come from /api/state (missed_ticks) at the
// start and end of the phase. Alternating phases in one run keeps machine load comparable.
//
//   viewer_load [--seconds S] [--rounds N] [--timing fast|wire] [--quick]
// Exit 77 when chromium is not installed.
#include <fcntl.h>
#include <httplib.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "latency_stats.h"
#include "load_phase.h"
#include "reference_client.h"
#include "tool_command_line.h"
#include "viewer_poller.h"

namespace {

using doppel::bench::add;
using doppel::bench::measure;
using doppel::bench::Phase;
using doppel::bench::print_row;
using doppel::bench::Poller;
using doppel::bench::state;

using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::SerialClient;

constexpr uint32_t kBaud = 1000000;

std::string find_chromium() {
  for (const char* path : {"/usr/bin/chromium", "/usr/bin/chromium-browser"}) {
    if (std::filesystem::exists(path)) return path;
  }
  return "";
}

// Headless Chromium showing `url` until stopped (its own process group, killed whole).
class Browser {
 public:
  Browser(const std::string& chromium, const std::string& url, const std::string& profile) {
    std::fflush(nullptr);  // the child must not print this process' buffered table again
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);
      const int null = open("/dev/null", O_WRONLY);
      dup2(null, 1);
      dup2(null, 2);
      const std::string profile_arg = "--user-data-dir=" + profile;
      execl(chromium.c_str(), chromium.c_str(), "--headless=new", "--no-sandbox", "--no-first-run",
            "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-dev-shm-usage",
            "--window-size=1280,900", profile_arg.c_str(), url.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~Browser() {
    if (pid_ > 0) {
      kill(-pid_, SIGTERM);
      int status = 0;
      waitpid(pid_, &status, 0);
      kill(-pid_, SIGKILL);  // helpers that outlived it
    }
  }
  Browser(const Browser&) = delete;
  Browser& operator=(const Browser&) = delete;

 private:
  pid_t pid_ = -1;
};

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5.0;
  int rounds = 3;
  std::string timing = "wire";
  bool quick = false;
  CLI::App app("Bus latency and missed simulation ticks with the web viewer open and closed", "viewer_load");
  app.add_option("--seconds", seconds, "seconds per phase")->check(CLI::PositiveNumber);
  app.add_option("--rounds", rounds, "closed/open pairs")->check(CLI::PositiveNumber);
  app.add_option("--timing", timing)->check(CLI::IsMember({"fast", "wire"}));
  app.add_flag("--quick", quick, "one round of 1 s phases");
  if (const std::optional<int> exit_code = doppel::bench::parse_command_line(
          app, argc, argv, "usage: viewer_load [--seconds S] [--rounds N] [--timing fast|wire] [--quick]\n")) {
    return *exit_code;
  }
  if (quick) {
    seconds = 1.0;
    rounds = 1;
  }
  const std::string chromium = find_chromium();
  if (chromium.empty()) {
    std::printf("viewer_load: SKIPPED: chromium is not installed (scripts/setup installs it)\n");
    return 77;
  }
  // --no-token: this tool polls the API as the page does, without a cookie jar; the token check is a
  // 32-byte compare per request.
  DoppelProcess doppel({"--viewer", "0", "--no-token", "--timing", timing});
  const std::string output = doppel.wait_for_output("viewer on http://127.0.0.1:");
  std::smatch match;
  if (!std::regex_search(output, match, std::regex(R"(viewer on (http://127\.0\.0\.1:(\d+)/))"))) {
    std::fprintf(stderr, "viewer_load: doppel serves no viewer:\n%s", output.c_str());
    return 1;
  }
  const std::string url = match[1].str();
  const int port = std::stoi(match[2].str());
  SerialClient client(doppel.link(), kBaud);
  const nlohmann::json cameras = state(port)["robots"][0]["cameras"];
  const std::string camera = cameras.empty() ? "" : cameras[0]["name"].get<std::string>();
  const std::string profile = doppel.link_dir() + "/../chromium";

  std::printf("doppel (fumanoid-2011, ODE, %s timing); READ 2 B of servo 1 back to back, %d x (%.1f s each: closed, polled, open)\n\n",
              timing.c_str(), rounds, seconds);
  std::printf("| phase | samples | p50 us | p99 us | p99.9 us | max us | failures | missed ticks | missed per s | sim / wall |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  Phase closed_total, polled_total, open_total;
  for (int round = 0; round < rounds; ++round) {
    const Phase closed = measure(client, port, seconds);
    print_row("closed", closed);
    add(closed_total, closed);
    Phase polled;
    {
      Poller poller(port, camera);
      polled = measure(client, port, seconds);
      polled.failures += poller.failures.load();
    }
    print_row("polled", polled);
    add(polled_total, polled);
    Phase open;
    {
      Browser browser(chromium, url, profile);
      std::this_thread::sleep_for(std::chrono::seconds(3));  // page loaded, three.js running
      open = measure(client, port, seconds);
    }
    print_row("open", open);
    add(open_total, open);
  }
  print_row("**all closed**", closed_total);
  print_row("**all polled**", polled_total);
  print_row("**all open**", open_total);
  doppel.stop();
  const int failures = closed_total.failures + polled_total.failures + open_total.failures;
  return failures == 0 ? 0 : 1;
}
