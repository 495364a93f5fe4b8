#pragma once
// The EEPROM areas of a robot's devices kept across runs of doppel, as a real robot's servos keep
// their ID, baud rate, Protocol Type and limits across power cycles. One JSON file per robot in the
// state directory (README "State"): robot name, the robot file, a hash of its bus/device layout and
// per device (by position in the robot file, not by ID, since the driver may change the ID) its
// model and its EEPROM bytes in hex. Files are replaced atomically (temporary file, fsync, rename,
// fsync of the directory), so a kill at any moment leaves the old file or the new one. Setup and
// the gateway's state thread only, never the bus threads.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gateway/robot_config.h"

namespace doppel::gateway {

// EEPROM bytes of every device of a robot, [bus][device] in robot-file order.
using RobotEeprom = std::vector<std::vector<std::vector<uint8_t>>>;

// $XDG_STATE_HOME/doppel when XDG_STATE_HOME is set, else $HOME/.local/state/doppel; "" without either.
std::string default_state_dir();

// The state file of robot `robot_index` (0 = the first --robot): DIR/<name>.json, DIR/<name>.robot<r>.json
// for r >= 1; characters other than letters, digits, '.', '_' and '-' in the name become '_'.
std::string state_file_path(const std::string& state_dir, const RobotConfig& robot, std::size_t robot_index);

// Stable hash (FNV-1a 64, hex) of the buses and the models on them, in file order.
std::string layout_hash(const RobotConfig& robot);

// Creates `dir` (and its parents, mode 0700) if missing and checks that files can be created in it.
// Throws std::runtime_error naming the directory and the reason.
void prepare_state_dir(const std::string& dir);

// The saved EEPROM of `robot` from `path`; nullopt when there is no such file. Throws
// std::runtime_error naming the file when it cannot be read, is not a state file, or was written
// for another robot or layout (the message suggests --fresh).
std::optional<RobotEeprom> read_state(const std::string& path, const RobotConfig& robot);

// The state file's text for `robot` with `eeprom`.
std::string state_json(const RobotConfig& robot, const RobotEeprom& eeprom, const std::vector<std::vector<uint16_t>>& model_numbers);

// Replaces `path` with `text` atomically. Throws std::runtime_error naming the path and the reason.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace doppel::gateway
