#pragma once
// The command line of the end-to-end bench tools, parsed by CLI11 like doppel's own: the tool declares
// its options on a CLI::App, this adds --help and turns a bad line into the tool's usage and exit 2.

#include <CLI/CLI.hpp>

#include <cstdio>
#include <optional>

#include "base/command_line.h"

namespace doppel::bench {

// Parses argv into the options declared on `app`. nullopt: go on. Otherwise the tool exits with the
// returned code: 0 after --help (usage on stdout), 2 after a bad line (the error and usage on stderr).
inline std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv, const char* usage) {
  bool help = false;
  app.set_help_flag();
  app.add_flag("-h,--help", help);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "%s: %s\n%s", app.get_name().c_str(), e.what(), usage);
    return 2;
  }
  if (help) {
    std::fputs(usage, stdout);
    return 0;
  }
  return std::nullopt;
}

}  // namespace doppel::bench
