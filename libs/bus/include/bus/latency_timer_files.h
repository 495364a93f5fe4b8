#pragma once
// The FTDI latency-timer file of each bus, kept beside its link (`ttyDXL0.latency_timer`): a small
// regular file that holds the bus adapter's latency timer in ms ("16\n") as Linux's
// /sys/bus/usb-serial/devices/ttyUSB<n>/latency_timer does, so a driver that tunes its adapter
// through sysfs (reached through doppel-run's preload library, shim/) changes the bus' adapter
// model while doppel runs. One non-real-time thread watches every file (inotify IN_CLOSE_WRITE),
// reads what was written (base/latency_timer.h: 1..255) and hands it to the bus server, which
// applies it lock-free before its next reply. Bad content is refused with a message naming the
// file, and the file is rewritten with the value in force, as the sysfs file never holds one.

#include <sys/types.h>

#include <ostream>
#include <string>
#include <thread>
#include <vector>

#include "bus/bus_server.h"

namespace doppel::bus {

class LatencyTimerFiles {
 public:
  // Messages (a changed or refused value) go to `messages` from the watcher thread. Throws
  // std::runtime_error when inotify is unavailable. Setup only.
  explicit LatencyTimerFiles(std::ostream& messages);
  // Stops the watcher and removes the files that are still the ones created here.
  ~LatencyTimerFiles();
  LatencyTimerFiles(const LatencyTimerFiles&) = delete;
  LatencyTimerFiles& operator=(const LatencyTimerFiles&) = delete;

  // Creates (or truncates a stale) `path` (never through a symlink) holding the server's latency
  // timer, and watches it; `server` must outlive this object. Call before start(). Setup; throws
  // std::runtime_error naming the path when a system call fails.
  void add(const std::string& path, BusServer& server);

  // Starts the watcher thread; idempotent.
  void start();
  // Stops and joins it; idempotent.
  void stop();

  // `<link>.latency_timer`: where the latency-timer file of the bus at `link` lives.
  static std::string path_for_link(const std::string& link);

 private:
  struct Watched {
    std::string path;
    BusServer* server;
    int watch;   // inotify watch descriptor
    dev_t dev;   // identity of the file created here, so a replaced file is left alone at exit
    ino_t ino;
    int pin_fd;  // held open until exit: the inode stays allocated, so no replacement can reuse its number
  };

  void watch_loop() noexcept;
  void on_written(const Watched& file);
  static void write_value(const std::string& path, uint32_t latency_ms);

  std::ostream& messages_;
  int inotify_fd_ = -1;
  int stop_fd_ = -1;  // eventfd that wakes the watcher to stop
  std::vector<Watched> files_;
  std::thread thread_;
};

}  // namespace doppel::bus
