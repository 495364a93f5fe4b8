#include "gateway/options.h"

#include <charconv>
#include <stdexcept>
#include <string_view>

namespace doppel::gateway {
namespace {

template <typename T>
T parse_number(std::string_view option, std::string_view text, T min, T max) {
  T value{};
  auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc{} || end != text.data() + text.size() || value < min || value > max) {
    throw std::invalid_argument("option " + std::string(option) + ": '" + std::string(text) +
                                "' is not a number in [" + std::to_string(min) + ", " + std::to_string(max) + "]");
  }
  return value;
}

}  // namespace

std::string usage() {
  return R"(Usage: doppel [OPTIONS]

Emulates the Dynamixel buses of one or more robots on pseudo-terminals, so that unmodified
servo-bus drivers can talk to a simulated robot. Runs until SIGINT or SIGTERM.

Options:
  --robot NAME|FILE      Robot description: a shipped robot name (see --list-robots) or a
                         protobuf text file. Repeat to run several robots. Default: fumanoid-2011.
  --link-dir DIR         Directory for the stable port links. Default: $XDG_RUNTIME_DIR/doppel,
                         or /tmp/doppel-$USER without a private XDG_RUNTIME_DIR.
                         Robot 0, bus b:  DIR/ttyDXL<b>        (e.g. /tmp/doppel-$USER/ttyDXL0)
                         Robot r>0, bus b: DIR/robot<r>/ttyDXL<b>
                         Refused if it is a symlink, another user's, or writable by others.
  --allow-shared-link-dir
                         Use such a link directory anyway, with a warning.
  --timing wire|fast     wire (default): statuses arrive when a real bus at the port's baud rate
                         would deliver them (wire time, firmware time, Return Delay Time).
                         fast: statuses are written as soon as they are computed.
  --processing-us US     Firmware processing time before the Return Delay Time starts, in µs
                         (default 50, as measured on MX-64 servos).
  --latency-timer MS     Model a USB serial adapter (FTDI/U2D2) whose latency timer is MS ms
                         (1..255; FTDI default 16). Default 0: no adapter model.
  --physics ode|bullet|none
                         Physics engine for the robots' bodies (default ode). Robots whose file has
                         no body, and every robot with 'none', move kinematically: joints turn toward
                         their goals at the commanded speed, the IMU lies level, the feet carry the
                         weight evenly.
  --no-hold              Release every robot at start. By default a robot is held in its initial
                         pose, as a handler holds a real robot while it powers up, until its
                         driver first enables torque on one of its servos.
  --session FILE         Session file (protobuf text, proto/session.proto): cameras fixed in the
                         field, such as sessions/sideline-camera.textproto (a TV view from the touch
                         line). They stream like the robots' cameras, also with --physics none.
  --no-camera            Stream no camera. By default every camera of a simulated robot's description
                         (the default robot's head camera: 640x480 YUYV, 20 fps, wide lens) streams
                         through iceoryx shared memory; see doppel-camera.
  --external-roudi       Use an iceoryx RouDi that is already running (iox-roudi) and fail without one.
                         By default doppel uses a running RouDi if there is one and otherwise runs
                         RouDi inside itself.
  --verbose              Also print iceoryx's own log lines (warnings and info).
  --rt-priority P        Run the bus I/O threads with SCHED_FIFO priority P (1..99; needs
                         CAP_SYS_NICE or root). Default 0: normal scheduling. Cuts the latency
                         tail on a loaded machine.
  --robots-dir DIR       Where robot names are looked up (default: the robots/ folder of the source tree,
                         or $DOPPEL_ROBOTS_DIR).
  --list-robots          Print the shipped robots and exit.
  --help                 Print this text and exit.

The port baud rate set by the driver (termios, including BOTHER rates) must match the devices'
Baud Rate registers, as on real hardware; the robot file sets them (fumanoid-2011: 1 Mbps).
)";
}

Options parse_options(int argc, const char* const* argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    std::string_view arg = argv[i];
    auto value = [&]() -> std::string_view {
      if (i + 1 >= argc) {
        throw std::invalid_argument("option " + std::string(arg) + " needs a value (see --help)");
      }
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      options.help = true;
    } else if (arg == "--list-robots") {
      options.list_robots = true;
    } else if (arg == "--robot") {
      options.robots.emplace_back(value());
    } else if (arg == "--link-dir") {
      options.link_dir = value();
      if (options.link_dir.empty()) {
        throw std::invalid_argument("option --link-dir: the directory must not be empty");
      }
    } else if (arg == "--allow-shared-link-dir") {
      options.allow_shared_link_dir = true;
    } else if (arg == "--robots-dir") {
      options.robots_dir = value();
    } else if (arg == "--session") {
      options.session = value();
      if (options.session.empty()) {
        throw std::invalid_argument("option --session: the file name must not be empty");
      }
    } else if (arg == "--timing") {
      std::string_view mode = value();
      if (mode == "wire") {
        options.timing = bus::TimingMode::kWire;
      } else if (mode == "fast") {
        options.timing = bus::TimingMode::kFast;
      } else {
        throw std::invalid_argument("option --timing: '" + std::string(mode) + "' is neither 'wire' nor 'fast'");
      }
    } else if (arg == "--processing-us") {
      options.processing_us = parse_number<double>(arg, value(), 0.0, 10000.0);
    } else if (arg == "--physics") {
      options.physics = value();
      if (options.physics != "ode" && options.physics != "bullet" && options.physics != "none") {
        throw std::invalid_argument("option --physics: '" + options.physics + "' is not one of ode, bullet, none");
      }
    } else if (arg == "--no-camera") {
      options.camera = false;
    } else if (arg == "--external-roudi") {
      options.external_roudi = true;
    } else if (arg == "--verbose") {
      options.verbose = true;
    } else if (arg == "--no-hold") {
      options.hold = false;
    } else if (arg == "--rt-priority") {
      options.rt_priority = parse_number<int>(arg, value(), 0, 99);
    } else if (arg == "--latency-timer") {
      options.latency_timer_ms = parse_number<uint32_t>(arg, value(), 0, 255);
    } else {
      throw std::invalid_argument("unknown option '" + std::string(arg) + "' (see --help)");
    }
  }
  if (options.robots.empty()) {
    options.robots.emplace_back("fumanoid-2011");
  }
  return options;
}

}  // namespace doppel::gateway
