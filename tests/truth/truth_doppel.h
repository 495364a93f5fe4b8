#pragma once
// doppel --world-model for the end-to-end tests: its control API on a free port (doppel-ctl), the
// truth UDP port of robot 0 bound by the test first, and the next message that passes a check.

#include <chrono>
#include <functional>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "proto/truth.pb.h"
#include "truth/subscriber.h"

namespace doppel::testing {

using nlohmann::json;
using proto::truth::WorldModel;

// doppel --world-model with its control API on a free port, the truth UDP port of robot 0 bound here first.
struct TruthDoppel {
  explicit TruthDoppel(std::vector<std::string> args, bool iceoryx = false)
      : udp(0), doppel([&] {
          args.insert(args.end(), {"--world-model", "--truth-udp-port", std::to_string(udp.port()), "--viewer", "0",
                                   "--timing", "fast"});
          if (!iceoryx) args.push_back("--no-truth-iceoryx");
          return args;
        }()) {
    const std::string output = doppel.wait_for_output("simulation control on http://127.0.0.1:");
    std::smatch match;
    if (!std::regex_search(output, match, std::regex(R"(simulation control on http://127\.0\.0\.1:(\d+))"))) {
      throw std::runtime_error("doppel did not say where its control is: " + output);
    }
    url = "http://127.0.0.1:" + match[1].str();
  }
  std::pair<int, std::string> ctl(const std::string& arguments) const {
    return run_command(std::string(DOPPEL_CTL) + " --url " + url + " " + arguments);
  }
  json ok(const std::string& arguments) const {
    const auto [code, output] = ctl(arguments);
    EXPECT_EQ(code, 0) << "doppel-ctl " << arguments << ": " << output;
    json answer = json::parse(output, nullptr, false);
    EXPECT_FALSE(answer.is_discarded()) << output;
    return answer;
  }
  // The next robot-0 message over UDP for which `accept` holds (60 s: a loaded machine runs slowly).
  WorldModel next(const std::function<bool(const WorldModel&)>& accept) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (std::chrono::steady_clock::now() < deadline) {
      const std::optional<truth::Datagram> d = udp.receive(1.0);
      if (!d) continue;
      EXPECT_EQ(d->robot, 0u);
      EXPECT_EQ(d->topic, "world_model");
      WorldModel m;
      EXPECT_TRUE(m.ParseFromString(d->payload));
      if (accept(m)) return m;
    }
    ADD_FAILURE() << "no such world-model message within 60 s; " << doppel.output();
    return {};
  }
  truth::UdpReceiver udp;
  DoppelProcess doppel;
  std::string url;
};

}  // namespace doppel::testing
