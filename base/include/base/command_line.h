#pragma once
// Number checks for the command lines of Doppel's executables and tools, all parsed by CLI11: one
// conversion (CLI11's) and one wording for a value that is not a number or out of range.

#include <CLI/CLI.hpp>

#include <sstream>
#include <string>

namespace doppel {

// Accepts a value that CLI11 converts to T and that lies in [min, max]; otherwise the error reads
// "'<value>' is not a number in [<min>, <max>]" (CLI11 puts the option's name in front).
template <typename T>
CLI::Validator number_in(T min, T max) {
  return CLI::Validator(
      [min, max](std::string& text) {
        T value{};
        if (CLI::detail::lexical_cast(text, value) && min <= value && value <= max) {
          return std::string();
        }
        std::ostringstream message;
        message << "'" << text << "' is not a number in [" << min << ", " << max << "]";
        return message.str();
      },
      "NUMBER");
}

// Accepts a value that CLI11 converts to T and that is > 0.
template <typename T>
CLI::Validator positive_number() {
  return CLI::Validator(
      [](std::string& text) {
        T value{};
        if (CLI::detail::lexical_cast(text, value) && value > T{}) {
          return std::string();
        }
        return "'" + text + "' is not a positive number";
      },
      "NUMBER");
}

}  // namespace doppel
