// first_answer: how long after a PING sent the moment the link appears its status arrives, over N
// starts of the real `doppel` with its defaults (camera, viewer, handshake, physics), against the
// wire model of that PING (the target: the model + 5 ms). Also when the link appeared after the
// start. DOPPEL_EXECUTABLE=PATH measures another build (e.g. main's, for a before/after table).
// Exit code 1 only for a wrong or missing answer.
//
//   first_answer [--starts N] [--load P] [-- DOPPEL_ARGS...]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "reference_client.h"
#include "reopen_stress.h"
#include "tool_command_line.h"
#include "watched_doppel.h"

namespace {

using Clock = std::chrono::steady_clock;
using doppel::testing::Bytes;

// PING ID 1 on the default robot's bus (1 Mbps, RX-28): 6 bytes out, 6 back at 10 us a byte, 50 us
// firmware time (doppel's default) and the Return Delay Time 250 (500 us) = 670 us.
constexpr double kModelUs = 12 * 10.0 + 50.0 + 500.0;
constexpr double kTargetUs = kModelUs + 5000.0;

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  return values[static_cast<std::size_t>(p * static_cast<double>(values.size() - 1))];
}

}  // namespace

int main(int argc, char** argv) {
  int starts = 20;
  int load = 0;
  std::vector<std::string> doppel_args;
  CLI::App app("The first PING's answer after doppel starts", "first_answer");
  app.add_option("--starts", starts)->check(CLI::PositiveNumber);
  app.add_option("--load", load)->check(CLI::NonNegativeNumber);
  app.add_option("doppel_args", doppel_args);
  if (auto exit_code = doppel::bench::parse_command_line(
          app, argc, argv, "usage: first_answer [--starts N] [--load P] [-- DOPPEL_ARGS...]\n")) {
    return *exit_code;
  }
  const Bytes ping = {0xFF, 0xFF, 0x01, 0x02, 0x01, 0xFB};
  const Bytes status = {0xFF, 0xFF, 0x01, 0x02, 0x00, 0xFC};
  std::vector<double> link_ms, answer_us;
  int wrong = 0, over_target = 0;
  doppel::testing::BusyLoad busy(load);
  for (int i = 0; i < starts; ++i) {
    const auto started = Clock::now();
    doppel::testing::WatchedDoppel doppel(doppel_args);
    const std::string link = doppel.wait_for_link("ttyDXL0");
    const auto appeared = Clock::now();
    doppel::testing::SerialClient client(link, 1'000'000);
    const auto sent = Clock::now();
    client.send(ping);
    const Bytes reply = client.receive(status.size(), 10'000);
    const auto answered = Clock::now();
    link_ms.push_back(std::chrono::duration<double, std::milli>(appeared - started).count());
    answer_us.push_back(std::chrono::duration<double, std::micro>(answered - sent).count());
    wrong += reply == status ? 0 : 1;
    over_target += answer_us.back() > kTargetUs ? 1 : 0;
    std::printf("start %2d: link after %7.1f ms, first answer after %9.1f us%s\n", i + 1, link_ms.back(),
                answer_us.back(), reply == status ? "" : " (wrong or no answer)");
    std::fflush(stdout);
  }
  std::printf("\n%d starts, %d busy processes; wire model %.0f us, target %.0f us\n", starts, load, kModelUs, kTargetUs);
  std::printf("| | p50 | p90 | max |\n|---|---|---|---|\n");
  std::printf("| link appears after start, ms | %.1f | %.1f | %.1f |\n", percentile(link_ms, 0.5), percentile(link_ms, 0.9),
              percentile(link_ms, 1.0));
  std::printf("| first answer after the PING, us | %.0f | %.0f | %.0f |\n", percentile(answer_us, 0.5),
              percentile(answer_us, 0.9), percentile(answer_us, 1.0));
  std::printf("over the target: %d of %d; wrong or missing answers: %d\n", over_target, starts, wrong);
  return wrong == 0 ? 0 : 1;  // the timing is a figure to read, not a verdict
}
