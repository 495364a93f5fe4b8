#include "eeprom_state.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace doppel::gateway {
namespace {

constexpr const char* kFormat = "doppel-eeprom-state 1";
constexpr const char* kFreshHint = " (--fresh starts from the robot file and overwrites it)";

std::string hex(const std::vector<uint8_t>& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  for (uint8_t b : bytes) {
    out += kDigits[b >> 4];
    out += kDigits[b & 0xF];
  }
  return out;
}

std::optional<std::vector<uint8_t>> from_hex(const std::string& text) {
  if (text.size() % 2 != 0) {
    return std::nullopt;
  }
  std::vector<uint8_t> bytes;
  for (std::size_t i = 0; i < text.size(); i += 2) {
    const auto nibble = [](char c) -> int {
      if (c >= '0' && c <= '9') return c - '0';
      if (c >= 'a' && c <= 'f') return c - 'a' + 10;
      if (c >= 'A' && c <= 'F') return c - 'A' + 10;
      return -1;
    };
    const int high = nibble(text[i]);
    const int low = nibble(text[i + 1]);
    if (high < 0 || low < 0) {
      return std::nullopt;
    }
    bytes.push_back(static_cast<uint8_t>(high * 16 + low));
  }
  return bytes;
}

std::string errno_text(int error) { return std::strerror(error); }

}  // namespace

std::string default_state_dir() {
  if (const char* state = std::getenv("XDG_STATE_HOME"); state != nullptr && *state == '/') {
    return std::string(state) + "/doppel";
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0') {
    return std::string(home) + "/.local/state/doppel";
  }
  return {};
}

std::string state_file_path(const std::string& state_dir, const RobotConfig& robot, std::size_t robot_index) {
  std::string name = robot.name;
  for (char& c : name) {
    const bool plain = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                       c == '_' || c == '-';
    if (!plain) c = '_';
  }
  if (name.empty() || name.front() == '.') {
    name = "_" + name;
  }
  return state_dir + "/" + name + (robot_index == 0 ? "" : ".robot" + std::to_string(robot_index)) + ".json";
}

std::string layout_hash(const RobotConfig& robot) {
  uint64_t hash = 0xcbf29ce484222325ULL;
  const auto mix = [&hash](const std::string& text) {
    for (unsigned char c : text) {
      hash = (hash ^ c) * 0x100000001b3ULL;
    }
    hash = (hash ^ 0xFF) * 0x100000001b3ULL;  // separator
  };
  for (const BusConfig& bus : robot.buses) {
    mix("bus");
    for (const DeviceConfig& device : bus.devices) {
      mix(device.model);
      mix(device.firmware == dynamixel::Protocol::kV1 ? "p1" : "p2");
    }
  }
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hash));
  return text;
}

void prepare_state_dir(const std::string& dir) {
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) {
    throw std::runtime_error("state directory " + dir + " cannot be created: " + error.message() +
                             " (--state-dir DIR chooses another)");
  }
  ::chmod(dir.c_str(), 0700);  // best effort for a directory we just made; an existing one keeps its mode
  const std::string probe = dir + "/.doppel-write-test." + std::to_string(::getpid());
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
  if (fd < 0) {
    throw std::runtime_error("state directory " + dir + " is not writable: " + errno_text(errno) +
                             " (--state-dir DIR chooses another)");
  }
  ::close(fd);
  ::unlink(probe.c_str());
}

std::optional<RobotEeprom> read_state(const std::string& path, const RobotConfig& robot) {
  std::ifstream in(path);
  if (!in) {
    if (!std::filesystem::exists(path)) {
      return std::nullopt;
    }
    throw std::runtime_error("state file " + path + " cannot be read: " + errno_text(errno));
  }
  const auto fail = [&path](const std::string& what) -> std::runtime_error {
    return std::runtime_error("state file " + path + ": " + what + kFreshHint);
  };
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw fail(std::string("corrupt, not JSON (") + e.what() + ")");
  }
  try {
    if (!json.is_object() || json.value("format", "") != kFormat) {
      throw fail(std::string("not a doppel state file (no \"format\": \"") + kFormat + "\")");
    }
    if (json.at("robot").get<std::string>() != robot.name) {
      throw fail("written for robot '" + json.at("robot").get<std::string>() + "', not '" + robot.name + "'");
    }
    const nlohmann::json& buses = json.at("buses");
    const bool same_layout = json.at("layout").get<std::string>() == layout_hash(robot);
    if (!same_layout || !buses.is_array() || buses.size() != robot.buses.size()) {
      throw fail("written for another bus/device layout than " + robot.source + "'s");
    }
    RobotEeprom eeprom(robot.buses.size());
    for (std::size_t b = 0; b < robot.buses.size(); ++b) {
      const nlohmann::json& devices = buses.at(b).at("devices");
      if (!devices.is_array() || devices.size() != robot.buses[b].devices.size()) {
        throw fail("bus " + std::to_string(b) + " has another number of devices than in " + robot.source);
      }
      for (std::size_t d = 0; d < devices.size(); ++d) {
        const DeviceConfig& device = robot.buses[b].devices[d];
        const nlohmann::json& saved = devices.at(d);
        if (saved.at("model").get<std::string>() != device.model) {
          throw fail("bus " + std::to_string(b) + " device " + std::to_string(d) + " is a " +
                     saved.at("model").get<std::string>() + " in the state, a " + device.model + " in " + robot.source);
        }
        std::optional<std::vector<uint8_t>> bytes = from_hex(saved.at("eeprom").get<std::string>());
        if (!bytes) {
          throw fail("bus " + std::to_string(b) + " device " + std::to_string(d) + ": eeprom is not hex bytes");
        }
        eeprom[b].push_back(std::move(*bytes));
      }
    }
    return eeprom;
  } catch (const nlohmann::json::exception& e) {
    throw fail(std::string("corrupt (") + e.what() + ")");
  }
}

std::string state_json(const RobotConfig& robot, const RobotEeprom& eeprom,
                       const std::vector<std::vector<uint16_t>>& model_numbers) {
  nlohmann::json json;
  json["format"] = kFormat;
  json["robot"] = robot.name;
  json["robot_file"] = robot.source;
  json["layout"] = layout_hash(robot);
  json["buses"] = nlohmann::json::array();
  for (std::size_t b = 0; b < robot.buses.size(); ++b) {
    nlohmann::json bus;
    bus["name"] = robot.buses[b].name;
    bus["devices"] = nlohmann::json::array();
    for (std::size_t d = 0; d < robot.buses[b].devices.size(); ++d) {
      const DeviceConfig& device = robot.buses[b].devices[d];
      bus["devices"].push_back({{"name", device.name},
                                {"model", device.model},
                                {"model_number", model_numbers[b][d]},
                                {"eeprom", hex(eeprom[b][d])}});
    }
    json["buses"].push_back(std::move(bus));
  }
  return json.dump(1) + "\n";
}

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::filesystem::path target(path);
  const std::string dir = target.has_parent_path() ? target.parent_path().string() : ".";
  const std::string temporary = path + ".tmp." + std::to_string(::getpid());
  const auto fail = [&](const std::string& what, int error) {
    ::unlink(temporary.c_str());
    return std::runtime_error("cannot write state file " + path + ": " + what + ": " + errno_text(error));
  };
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) {
    throw fail("create " + temporary, errno);
  }
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      const int error = errno;
      ::close(fd);
      throw fail("write", error);
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    throw fail("fsync", error);
  }
  ::close(fd);
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    throw fail("rename", errno);
  }
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
}

}  // namespace doppel::gateway
