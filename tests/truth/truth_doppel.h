#pragma once
// doppel --world-model for the end-to-end tests: its control API on a free port (doppel-ctl), the
// truth UDP port of robot 0 bound by the test first, and the next message that passes a check.

#include <chrono>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "controlled_doppel.h"
#include "proto/truth.pb.h"
#include "truth/subscriber.h"

namespace doppel::testing {

using nlohmann::json;
using proto::truth::WorldModel;

// Robot 0's truth UDP port, bound before doppel starts (a base of TruthDoppel, so it comes first).
struct TruthPort {
  truth::UdpReceiver udp{0};
};

// doppel --world-model with its control API on a free port, the truth UDP port of robot 0 bound here first.
struct TruthDoppel : TruthPort, ControlledDoppel {
  explicit TruthDoppel(std::vector<std::string> args, bool iceoryx = false)
      : ControlledDoppel([&] {
          args.insert(args.end(), {"--world-model", "--truth-udp-port", std::to_string(udp.port())});
          if (!iceoryx) args.push_back("--no-truth-iceoryx");
          return args;
        }()) {}
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
};

}  // namespace doppel::testing
