// README's option list is the one `doppel --help` prints (generated from each service's option
// declarations, services/gateway/src/options.cpp): a group per service, every option with its value's
// label. When they disagree this test prints the block README should have.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "gateway/options.h"

namespace doppel::gateway {
namespace {

constexpr const char* kBegin = "<!-- the option list of doppel --help; tests/gateway/readme_options_test.cpp checks it -->";
constexpr const char* kEnd = "<!-- end of the option list -->";

// The option list of a --help text as README shows it: one line per group, "- Group: `--a X`, `--b`".
std::string option_list(const std::string& help) {
  std::istringstream lines(help);
  std::string line, group, out, options;
  const auto flush = [&] {
    if (!options.empty()) out += "- " + group + ": " + options + "\n";
    options.clear();
  };
  while (std::getline(lines, line)) {
    if (!line.empty() && line.back() == ':' && line[0] != ' ' && line.rfind("Usage", 0) != 0) {
      flush();
      group = line.substr(0, line.size() - 1);
    } else if (line.rfind("  -", 0) == 0 && !group.empty()) {
      std::string option = line.substr(2);
      option = option.substr(0, option.find("  "));  // the description follows after two spaces
      option = option.substr(0, option.find('='));   // the default stays in --help
      if (!options.empty()) options += ", ";
      options += "`" + option + "`";
    }
  }
  flush();
  return out;
}

TEST(ReadmeOptions, TheOptionListIsTheOneOfHelp) {
  const std::string expected = option_list(usage());
  ASSERT_NE(expected.find("- Robots and their buses: `--robot NAME|FILE`"), std::string::npos) << expected;
  std::ifstream file(std::string(DOPPEL_ROBOTS_DIR) + "/../../README.md");
  ASSERT_TRUE(file) << "README.md";
  const std::string readme((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  const std::size_t begin = readme.find(kBegin);
  const std::size_t end = readme.find(kEnd);
  ASSERT_NE(begin, std::string::npos) << "README.md has no " << kBegin;
  ASSERT_NE(end, std::string::npos) << "README.md has no " << kEnd;
  const std::size_t first = begin + std::string(kBegin).size() + 1;
  EXPECT_EQ(readme.substr(first, end - first), expected) << "README.md's option list should read:\n"
                                                         << kBegin << "\n" << expected << kEnd;
}

TEST(ReadmeOptions, TheListFollowsHelp) {
  const std::string help =
      "Usage: doppel [OPTIONS]\n\nOptions:\n  -h,--help               Print this.\n\nWorld:\n"
      "  --physics ode|bullet|none=ode\n                          Engine.\n  --no-hold               Release.\n";
  EXPECT_EQ(option_list(help), "- Options: `-h,--help`\n- World: `--physics ode|bullet|none`, `--no-hold`\n");
}

}  // namespace
}  // namespace doppel::gateway
