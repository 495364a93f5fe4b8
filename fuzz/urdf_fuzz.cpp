// Arbitrary bytes as the URDF a robot file names (figure { urdf { file: "fuzz.urdf" } }): TinyXML,
// urdfdom, the link tree, inertials, geometry, mesh URIs, the joint map. Must never crash; a bad
// URDF is refused with std::invalid_argument or std::runtime_error whose message starts with the
// robot file's name and stays short (names from the URDF are shortened in messages).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>

#include "proto/text_file.h"
#include "urdf/urdf_import.h"

namespace {

const std::string& directory() {
  static const std::string dir = [] {
    char pattern[] = "/tmp/doppel-urdf-fuzz-XXXXXX";
    const char* made = mkdtemp(pattern);
    if (made == nullptr) std::abort();
    return std::string(made);
  }();
  return dir;
}

void check_message(const std::string& message, const std::string& robot_file) {
  const bool ok = message.rfind(robot_file, 0) == 0 && message.size() < 4096;
  if (!ok) {
    std::fprintf(stderr, "bad error message (%zu bytes): %.300s\n", message.size(), message.c_str());
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > doppel::proto::TextFile::kMaxBytes) return 0;
  const std::string urdf = directory() + "/fuzz.urdf";
  {
    std::ofstream out(urdf, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  const std::string robot_file = directory() + "/fuzz.textproto";
  // Without a joint map (every movable joint is then refused) and with one for "swing".
  for (const char* joints : {"", "joint { name: \"swing\" passive: true }"}) {
    const std::string text = std::string("name: \"f\"\nfigure {\n  urdf { file: \"fuzz.urdf\" ") + joints +
                             " }\n  imu { name: \"IMU\" body: \"base\" bus: 0 id: 1 }\n}\n";
    try {
      doppel::urdf::parse_robot_file(text, robot_file);
    } catch (const std::exception& e) {
      check_message(e.what(), robot_file);
    }
  }
  return 0;
}
