#pragma once
// Number checks for the command lines of Doppel's executables and tools, all parsed by CLI11: one
// conversion (CLI11's) and one wording for a value that is not a number or out of range. They are
// CLI11 transforms (->transform), not checks: they may rewrite the text before it is converted.

#include <CLI/CLI.hpp>

#include <sstream>
#include <string>
#include <type_traits>

namespace doppel {

namespace detail {
// CLI11 reads an integer with a leading zero as octal ("010" = 8); a person typing 010 means ten.
// Drops the leading zeros of a decimal integer before CLI11 converts it (hexadecimal "0x.." stays).
template <typename T>
void as_decimal(std::string& text) {
  if constexpr (std::is_integral_v<T>) {
    const std::size_t digits = (!text.empty() && (text[0] == '-' || text[0] == '+')) ? 1 : 0;
    std::size_t first = digits;
    while (first + 1 < text.size() && text[first] == '0' && text[first + 1] >= '0' && text[first + 1] <= '9') {
      ++first;
    }
    text.erase(digits, first - digits);
  }
}
}  // namespace detail

// Accepts a value that CLI11 converts to T and that lies in [min, max]; otherwise the error reads
// "'<value>' is not a number in [<min>, <max>]" (CLI11 puts the option's name in front).
template <typename T>
CLI::Validator number_in(T min, T max) {
  return CLI::Validator(
      [min, max](std::string& text) {
        detail::as_decimal<T>(text);
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
        detail::as_decimal<T>(text);
        T value{};
        if (CLI::detail::lexical_cast(text, value) && value > T{}) {
          return std::string();
        }
        return "'" + text + "' is not a positive number";
      },
      "NUMBER");
}

}  // namespace doppel
