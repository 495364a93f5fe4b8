// doppel-run: starts an unmodified program with libdoppel_shim.so preloaded, so the serial devices
// it hard-codes (/dev/ttyUSB0, /dev/U2D2, ...) open Doppel's ports and answer as a USB serial
// adapter does (docs/shim.md). It checks every link first and never starts the program when one
// is missing or does not lead to a live pty.
#include <dirent.h>
#include <limits.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include "bus/link_directory.h"
#include "lockstep/clock_file.h"
#include "shim/port_map.h"

namespace {

using doppel::shim::kPortsVariable;

struct PortOption {
  std::string device;
  std::string link;
};

// Unix98 pty slaves (/dev/pts/N) have majors 136..143 (Documentation/admin-guide/devices.txt).
bool is_pty_slave(const struct stat& st) { return S_ISCHR(st.st_mode) && major(st.st_rdev) >= 136 && major(st.st_rdev) <= 143; }

// "" when `link` leads to a live pty; otherwise why not, for the user.
std::string link_problem(const std::string& link) {
  struct stat st {};
  if (::lstat(link.c_str(), &st) != 0) return link + " does not exist (" + std::strerror(errno) + "): is doppel running?";
  if (::stat(link.c_str(), &st) != 0) {
    return link + " leads nowhere (" + std::strerror(errno) + "): doppel has stopped (a stale link)";
  }
  if (!is_pty_slave(st)) return link + " is not a pseudo-terminal, so it is not one of Doppel's ports";
  return {};
}

// ttyDXL<n> entries of `dir`, sorted by n.
std::vector<int> bus_numbers(const std::string& dir) {
  std::vector<int> numbers;
  DIR* d = ::opendir(dir.c_str());
  if (d == nullptr) return numbers;
  while (const dirent* entry = ::readdir(d)) {
    const std::string name = entry->d_name;
    if (name.rfind("ttyDXL", 0) != 0 || name.size() == 6 || name.size() > 9) continue;
    if (!std::all_of(name.begin() + 6, name.end(), [](char c) { return c >= '0' && c <= '9'; })) continue;
    numbers.push_back(std::stoi(name.substr(6)));
  }
  ::closedir(d);
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

// A library beside this executable (build tree) or in ../lib (installed).
std::string library_path(const std::string& file) {
  char self[PATH_MAX] = {};
  const ssize_t n = ::readlink("/proc/self/exe", self, sizeof(self) - 1);
  std::string dir = n > 0 ? std::string(self, static_cast<std::size_t>(n)) : std::string(".");
  dir = dir.substr(0, dir.rfind('/'));
  for (const std::string& candidate : {dir + "/" + file, dir + "/../lib/" + file}) {
    if (::access(candidate.c_str(), R_OK) == 0) return candidate;
  }
  return {};
}

// The camera map for the shim, "DEVICE=CAMERA[:...]"; "" with a message when an option is wrong.
// Default: /dev/video<n> -> "#<n>", the n-th camera of robot 0 (resolved when the program opens it).
std::string camera_spec(const std::vector<std::string>& options, std::string& error) {
  constexpr int kDefaultDevices = 8;
  std::string spec;
  if (options.empty()) {
    for (int n = 0; n < kDefaultDevices; ++n) {
      spec += (n == 0 ? "" : ":") + std::string("/dev/video") + std::to_string(n) + "=#" + std::to_string(n);
    }
    return spec;
  }
  for (const std::string& option : options) {
    const std::size_t equals = option.find('=');
    const std::string device = option.substr(0, equals);
    const std::string camera = equals == std::string::npos ? "" : option.substr(equals + 1);
    if (equals == std::string::npos || device.rfind("/dev/video", 0) != 0 || device.size() == 10 || camera.empty() ||
        camera.find(':') != std::string::npos || device.find(':') != std::string::npos || device.size() >= 128 ||
        camera.size() >= 128) {
      error = "--camera " + option + ": expected /dev/video<N>=CAMERA (a camera name of doppel-camera list, no ':')";
      return {};
    }
    spec += (spec.empty() ? "" : ":") + device + "=" + camera;
  }
  return spec;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{
      "Runs COMMAND with Doppel's serial-port shim: the devices it opens (/dev/ttyUSB0, /dev/U2D2, ...) are\n"
      "Doppel's ports and answer as a USB serial adapter (FTDI) does. See docs/shim.md.",
      "doppel-run"};
  std::vector<std::string> ports;
  std::string link_dir = doppel::bus::default_link_dir();
  std::vector<std::string> command;
  app.add_option("--port", ports,
                 "DEVICE=LINK: opening DEVICE opens Doppel's port LINK (repeatable). Default: /dev/ttyUSB<n>\n"
                 "and /dev/ttyACM<n> -> LINK-DIR/ttyDXL<n> for every ttyDXL<n> there, /dev/U2D2 -> ttyDXL0")
      ->allow_extra_args(false);  // one value per --port: the words after it are the command's
  std::vector<std::string> cameras;
  app.add_option("--camera", cameras,
                 "/dev/videoN=CAMERA: opening /dev/videoN opens a V4L2 capture device fed by Doppel's camera CAMERA\n"
                 "(repeatable; doppel-camera list names them). Default: /dev/video<n> -> the n-th camera of robot 0")
      ->allow_extra_args(false);
  app.add_option("--link-dir", link_dir, "Doppel's link directory (doppel --link-dir). Default: " + link_dir);
  bool lockstep = false;
  app.add_flag("--lockstep", lockstep,
               "Give COMMAND doppel's simulation time (doppel --lockstep; docs/lockstep.md): its clocks, sleeps and\n"
               "timeouts are simulation time, which advances only while all its threads wait");
  app.add_option("command", command, "the program and its arguments")->required();
  app.prefix_command();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  // CLI11 hands back the "--" that separated doppel-run's options from the command as a remaining
  // argument: it is not the command's.
  bool separator_dropped = false;
  for (const std::string& extra : app.remaining()) {
    if (extra == "--" && !separator_dropped) {
      separator_dropped = true;
      continue;
    }
    command.push_back(extra);
  }

  std::string camera_error;
  const std::string camera_map = camera_spec(cameras, camera_error);
  if (!camera_error.empty()) {
    std::cerr << "doppel-run: " << camera_error << "\n";
    return 2;
  }

  std::vector<PortOption> mappings;
  for (const std::string& port : ports) {
    const std::size_t equals = port.find('=');
    if (equals == std::string::npos) {
      std::cerr << "doppel-run: --port " << port << ": expected DEVICE=LINK\n";
      return 2;
    }
    mappings.push_back({port.substr(0, equals), port.substr(equals + 1)});
  }
  if (mappings.empty()) {
    for (const int n : bus_numbers(link_dir)) {
      const std::string link = link_dir + "/ttyDXL" + std::to_string(n);
      mappings.push_back({"/dev/ttyUSB" + std::to_string(n), link});
      mappings.push_back({"/dev/ttyACM" + std::to_string(n), link});
      if (n == 0) mappings.push_back({"/dev/U2D2", link});
    }
    if (mappings.empty()) {
      std::cerr << "doppel-run: no port link ttyDXL<n> in " << link_dir
                << ": is doppel running (with this --link-dir)? Or name the ports with --port DEVICE=LINK\n";
      return 1;
    }
  }

  std::string spec;
  for (const PortOption& mapping : mappings) {
    if (const std::string problem = link_problem(mapping.link); !problem.empty()) {
      std::cerr << "doppel-run: " << mapping.device << " -> " << problem << "\n";
      return 1;
    }
    spec += (spec.empty() ? "" : ":") + mapping.device + "=" + mapping.link;
  }
  doppel::shim::PortMap check;
  if (!check.parse(spec)) {
    std::cerr << "doppel-run: --port: " << check.error() << "\n";
    return 2;
  }
  const std::string shim = library_path("libdoppel_shim.so");
  if (shim.empty()) {
    std::cerr << "doppel-run: libdoppel_shim.so is neither beside doppel-run nor in ../lib: reinstall Doppel\n";
    return 1;
  }
  if (lockstep) {
    const std::string clock = link_dir + "/" + doppel::lockstep::kClockFileName;
    struct stat st {};
    if (::stat(clock.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
      std::cerr << "doppel-run: --lockstep: " << clock
                << " does not exist: is doppel running with --lockstep (and this --link-dir)?\n";
      return 1;
    }
    ::setenv(doppel::lockstep::kClockVariable, clock.c_str(), 1);
  } else {
    ::unsetenv(doppel::lockstep::kClockVariable);
  }
  const char* preload = std::getenv("LD_PRELOAD");
  const std::string preloads = preload != nullptr && *preload != '\0' ? shim + ":" + preload : shim;
  ::setenv("LD_PRELOAD", preloads.c_str(), 1);
  ::setenv(kPortsVariable, spec.c_str(), 1);
  ::setenv("DOPPEL_SHIM_CAMERAS", camera_map.c_str(), 1);
  if (const std::string v4l2 = library_path("libdoppel_v4l2.so"); !v4l2.empty()) ::setenv("DOPPEL_SHIM_V4L2", v4l2.c_str(), 1);

  std::vector<char*> exec_args;
  for (std::string& arg : command) exec_args.push_back(arg.data());
  exec_args.push_back(nullptr);
  ::execvp(exec_args[0], exec_args.data());
  std::cerr << "doppel-run: cannot run '" << command[0] << "': " << std::strerror(errno) << "\n";
  return 127;
}
