#pragma once
// doppel with its control API on a loopback port the system picks (--viewer 0), where it says it
// serves, and doppel-ctl against it, as a user drives it. Tests that include this define
// DOPPEL_CTL (the doppel-ctl executable) for their target. doppel-ctl finds the run's access token
// in the test's link directory, as it finds it in the default one for a user.

#include <gtest/gtest.h>

#include <regex>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "doppel_process.h"

namespace doppel::testing {

struct ControlledDoppel {
  // `fast`: --timing fast (answers at once); false: doppel's default wire timing.
  explicit ControlledDoppel(std::vector<std::string> args, bool fast = true) : doppel([&] {
    args.insert(args.end(), {"--viewer", "0"});
    if (fast) args.insert(args.end(), {"--timing", "fast"});
    return args;
  }()) {
    const std::string output = doppel.wait_for_output("simulation control on http://127.0.0.1:");
    std::smatch match;
    if (!std::regex_search(output, match, std::regex(R"(simulation control on http://127\.0\.0\.1:(\d+))"))) {
      throw std::runtime_error("doppel did not say where its control is: " + output);
    }
    url = "http://127.0.0.1:" + match[1].str();
    port = static_cast<uint16_t>(std::stoi(match[1].str()));
  }
  // Runs doppel-ctl with `arguments`: its exit code and output.
  std::pair<int, std::string> ctl(const std::string& arguments) const {
    return run_command(std::string(DOPPEL_CTL) + " --url " + url + " --link-dir " + doppel.link_dir() + " " + arguments);
  }
  // doppel-ctl that must succeed, its JSON answer.
  nlohmann::json ok(const std::string& arguments) const {
    const auto [code, output] = ctl(arguments);
    EXPECT_EQ(code, 0) << "doppel-ctl " << arguments << ": " << output;
    nlohmann::json answer = nlohmann::json::parse(output, nullptr, false);
    EXPECT_FALSE(answer.is_discarded()) << output;
    return answer;
  }
  DoppelProcess doppel;
  std::string url;
  uint16_t port = 0;
};

}  // namespace doppel::testing
