// bus_throughput: the thesis' Table 11 experiment against the real `doppel`. One or two robots
// with 1, 7 or 9 RX-64 servos each; every robot has its own client thread that, as fast as it
// can, sends each servo a WRITE of its goal position and a READ of its present position, and
// counts every reply that is missing or corrupt as an error (the thesis saw 12-36 %).
//
//   bus_throughput [--seconds S] [--timing fast|wire]
#include <sys/wait.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "doppel_process.h"
#include "tool_command_line.h"
#include "reference_client.h"

namespace {

using doppel::testing::Bytes;
using doppel::testing::DoppelProcess;
using doppel::testing::p1_instruction;
using doppel::testing::SerialClient;
using Clock = std::chrono::steady_clock;

std::string write_robot(const std::string& dir, int servos) {
  std::string path = dir + "/table11-" + std::to_string(servos) + ".textproto";
  std::ofstream out(path);
  out << "name: \"table11-" << servos << "\"\nbus {\n  baud_bps: 1000000\n  protocol: PROTOCOL_1\n";
  for (int id = 1; id <= servos; ++id) {
    out << "  device { id: " << id << " model: \"RX-64\" }\n";
  }
  out << "}\n";
  return path;
}

struct RobotResult {
  uint64_t frames = 0;        // rounds over all servos
  uint64_t transactions = 0;  // instructions sent
  uint64_t errors = 0;        // replies missing or corrupt
  uint64_t timeouts = 0;      // of those, nothing at all within the timeout
  uint64_t partial = 0;       // of those, fewer bytes than a status within the timeout
};

RobotResult drive(const std::string& port, int servos, double seconds) {
  SerialClient client(port, 1000000);
  RobotResult result;
  auto end = Clock::now() + std::chrono::duration<double>(seconds);
  uint16_t goal = 412;
  while (Clock::now() < end) {
    goal = static_cast<uint16_t>(goal == 412 ? 612 : 412);
    for (uint8_t id = 1; id <= servos; ++id) {
      Bytes write = p1_instruction(id, 0x03, {30, static_cast<uint8_t>(goal & 0xFF), static_cast<uint8_t>(goal >> 8)});
      Bytes read = p1_instruction(id, 0x02, {36, 2});
      auto ok = [&](const Bytes& reply, std::size_t bytes) {
        auto statuses = doppel::testing::parse_p1_statuses(reply);
        bool good = reply.size() == bytes && statuses && statuses->size() == 1 && (*statuses)[0].id == id &&
                    (*statuses)[0].error == 0;
        if (!good) {
          result.timeouts += reply.empty() ? 1 : 0;
          result.partial += !reply.empty() && reply.size() < bytes ? 1 : 0;
          client.drain(5);  // a late reply must not be taken for the next one
        }
        return good;
      };
      result.errors += ok(client.transact(write, 6, 100), 6) ? 0 : 1;
      result.errors += ok(client.transact(read, 8, 100), 8) ? 0 : 1;
      result.transactions += 2;
    }
    ++result.frames;
  }
  return result;
}

}  // namespace

int main(int argc, char** argv) {
  double seconds = 5.0;
  std::string timing = "fast";
  CLI::App app("Thesis table 11: bus throughput against doppel", "bus_throughput");
  app.add_option("--seconds", seconds)->transform(doppel::positive_number<double>());
  app.add_option("--timing", timing)->check(CLI::IsMember({"fast", "wire"}));
  if (auto exit_code = doppel::bench::parse_command_line(app, argc, argv,
                                                          "usage: bus_throughput [--seconds S] [--timing fast|wire]\n")) {
    return *exit_code;
  }
  char dir_template[] = "/tmp/doppel-table11-XXXXXX";
  std::string dir = mkdtemp(dir_template);
  uint64_t total_errors = 0;
  std::printf("timing %s, %.1f s per row, each transaction = one instruction + its status\n\n", timing.c_str(), seconds);
  std::printf("| robots | servos each | frames/s per robot | transactions/s (all robots) | errors | error rate | thesis error rate |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  const char* thesis[2][3] = {{"12.2 %", "23.1 %", "30.2 %"}, {"17.0 %", "25.2 %", "36.0 %"}};
  for (int robots = 1; robots <= 2; ++robots) {
    int column = 0;
    for (int servos : {1, 7, 9}) {
      std::string file = write_robot(dir, servos);
      std::vector<std::string> args{"--timing", timing};
      for (int r = 0; r < robots; ++r) {
        args.insert(args.end(), {"--robot", file});
      }
      DoppelProcess doppel(args, robots == 2 ? "robot1/ttyDXL0" : "ttyDXL0");
      std::vector<RobotResult> results(static_cast<std::size_t>(robots));
      std::vector<std::thread> threads;
      for (int r = 0; r < robots; ++r) {
        std::string port = doppel.link(r == 0 ? "ttyDXL0" : "robot" + std::to_string(r) + "/ttyDXL0");
        threads.emplace_back([&, r, port] { results[static_cast<std::size_t>(r)] = drive(port, servos, seconds); });
      }
      for (auto& thread : threads) {
        thread.join();
      }
      RobotResult sum;
      for (const RobotResult& result : results) {
        sum.frames += result.frames;
        sum.transactions += result.transactions;
        sum.errors += result.errors;
        sum.timeouts += result.timeouts;
        sum.partial += result.partial;
      }
      int status = doppel.stop();
      if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        ++sum.errors;
      }
      total_errors += sum.errors;
      if (sum.errors > 0) {
        std::fprintf(stderr, "row %d x %d: %llu timeouts, %llu partial replies; doppel said:\n%s\n", robots, servos,
                     static_cast<unsigned long long>(sum.timeouts), static_cast<unsigned long long>(sum.partial),
                     doppel.output().c_str());
      }
      std::printf("| %d | %d | %.0f | %.0f | %llu | %.3f %% | %s |\n", robots, servos,
                  static_cast<double>(sum.frames) / robots / seconds, static_cast<double>(sum.transactions) / seconds,
                  static_cast<unsigned long long>(sum.errors),
                  100.0 * static_cast<double>(sum.errors) / static_cast<double>(std::max<uint64_t>(sum.transactions, 1)),
                  thesis[robots - 1][column++]);
    }
  }
  std::filesystem::remove_all(dir);
  std::printf("\ntotal errors: %llu\n", static_cast<unsigned long long>(total_errors));
  return total_errors == 0 ? 0 : 1;
}
