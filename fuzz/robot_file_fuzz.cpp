// Arbitrary text as a robot file and as a session file: the protobuf text parser, the location
// index, the string limits and every semantic check. Must never crash; a bad file is refused with
// std::invalid_argument or std::runtime_error whose message starts with the file name and, when
// the error has a place, line and column.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "gateway/robot_config.h"
#include "proto/text_file.h"

namespace {

// Aborts with the message, so libFuzzer keeps the input that broke the rule.
void check_message(const std::string& message) {
  const bool ok = message.rfind("fuzz.textproto", 0) == 0 && message.size() < 4096;
  if (!ok) {
    std::fprintf(stderr, "bad error message (%zu bytes): %.300s\n", message.size(), message.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > doppel::proto::TextFile::kMaxBytes) return 0;  // refused before parsing
  const std::string text(reinterpret_cast<const char*>(data), size);
  const auto parse_robot = [](const std::string& t) { doppel::gateway::parse_robot(t, "fuzz.textproto"); };
  const auto parse_session = [](const std::string& t) { doppel::gateway::parse_session(t, "fuzz.textproto"); };
  for (void (*parse)(const std::string&) : {+parse_robot, +parse_session}) {
    try {
      parse(text);
    } catch (const std::exception& e) {  // std::invalid_argument or std::runtime_error
      check_message(e.what());
    }
  }
  return 0;
}
