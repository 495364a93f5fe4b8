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

// Where `doppel` (started with --viewer 0) says its control API serves, once it has said so:
// http://127.0.0.1:PORT. Throws when it ends without saying it.
inline std::string control_url(DoppelProcess& doppel) {
  const std::string output = doppel.wait_for_output("simulation control on http://127.0.0.1:");
  std::smatch match;
  if (!std::regex_search(output, match, std::regex(R"(simulation control on (http://127\.0\.0\.1:\d+))"))) {
    throw std::runtime_error("doppel did not say where its control is: " + output);
  }
  return match[1].str();
}

// doppel-ctl with `arguments` against `doppel`'s control API at `url`: its exit code and output.
inline std::pair<int, std::string> run_ctl(const DoppelProcess& doppel, const std::string& url, const std::string& arguments) {
  return run_command(std::string(DOPPEL_CTL) + " --url " + url + " --link-dir " + doppel.link_dir() + " " + arguments);
}

// doppel-ctl with `arguments` (pause, resume, ...) against `doppel`, started with --viewer 0; a
// failure of the test when it does not succeed.
inline void expect_ctl(DoppelProcess& doppel, const std::string& arguments) {
  const auto [code, said] = run_ctl(doppel, control_url(doppel), arguments);
  EXPECT_EQ(code, 0) << "doppel-ctl " << arguments << ": " << said;
}

struct ControlledDoppel {
  // `fast`: --timing fast (answers at once); false: doppel's default wire timing.
  explicit ControlledDoppel(std::vector<std::string> args, bool fast = true)
      : doppel([&] {
          args.insert(args.end(), {"--viewer", "0"});
          if (fast) args.insert(args.end(), {"--timing", "fast"});
          return args;
        }()),
        url(control_url(doppel)),
        port(static_cast<uint16_t>(std::stoi(url.substr(url.rfind(':') + 1)))) {}
  // Runs doppel-ctl with `arguments`: its exit code and output.
  std::pair<int, std::string> ctl(const std::string& arguments) const { return run_ctl(doppel, url, arguments); }
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
