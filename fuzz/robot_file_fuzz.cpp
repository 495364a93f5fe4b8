// Arbitrary text as a robot file and as a session file: the protobuf text parser, the location
// index, the string limits and every semantic check. Must never crash; a bad file is refused with
// std::invalid_argument or std::runtime_error whose message starts with the file name and, when
// the error has a place, line and column.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
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
  try {
    doppel::gateway::parse_robot(text, "fuzz.textproto");
  } catch (const std::invalid_argument& e) {
    check_message(e.what());
  } catch (const std::runtime_error& e) {
    check_message(e.what());
  }
  try {
    doppel::gateway::parse_session(text, "fuzz.textproto");
  } catch (const std::invalid_argument& e) {
    check_message(e.what());
  } catch (const std::runtime_error& e) {
    check_message(e.what());
  }
  return 0;
}
