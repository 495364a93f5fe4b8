#pragma once
// What parse_robot says about a robot file's text, for tests that check the refusals: the
// exception's message, or "no error" when the text is accepted.
#include <exception>
#include <string>

#include "gateway/robot_config.h"

namespace doppel::gateway {

inline std::string error_of(const std::string& text) {
  try {
    parse_robot(text, "robots/bad.textproto");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace doppel::gateway
