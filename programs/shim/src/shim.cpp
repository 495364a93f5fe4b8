// libdoppel_shim.so: the preload library doppel-run puts under an unmodified program (see
// docs/shim.md). It maps the device paths the program hard-codes to Doppel's port links and, for
// file descriptors of those ports only, answers what a USB serial adapter answers and a pty does
// not (ftdi_serial.h). Every other call goes to libc's own function untouched, errno included.
//
// Rules kept here: no allocation and no lock in an intercepted call (the port table, port_table.h,
// maps fd -> port with fixed atomics), no C++ exceptions (built with -fno-exceptions), messages written with write(2)
// once per problem, and a missing or bad environment never breaks the program: it then runs as if
// the library were not there.
#include <dlfcn.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <linux/close_range.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <string_view>

#include "base/latency_timer.h"
#include "base/pty_handover.h"
#include "line_rate.h"
#include "lockstep_shim.h"
#include "port_table.h"
#include "shim/ftdi_serial.h"
#include "shim/port_map.h"
#include "v4l2_shim.h"

#define SHIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace doppel::shim {
namespace {

struct Real {
  int (*open)(const char*, int, ...);
  int (*open64)(const char*, int, ...);
  int (*openat)(int, const char*, int, ...);
  int (*openat64)(int, const char*, int, ...);
  int (*open_2)(const char*, int);
  int (*open64_2)(const char*, int);
  int (*openat_2)(int, const char*, int);
  int (*openat64_2)(int, const char*, int);
  FILE* (*fopen)(const char*, const char*);
  FILE* (*fopen64)(const char*, const char*);
  int (*fclose)(FILE*);
  int (*close)(int);
  int (*close_range)(unsigned, unsigned, int);
  void (*closefrom)(int);
  int (*dup)(int);
  int (*dup2)(int, int);
  int (*dup3)(int, int, int);
  int (*fcntl)(int, int, ...);
  int (*fcntl64)(int, int, ...);
  int (*ioctl)(int, unsigned long, ...);
  int (*tcflush)(int, int);
  int (*tcsetattr)(int, int, const struct termios*);
  int (*stat)(const char*, struct stat*);
  int (*lstat)(const char*, struct stat*);
  int (*fstatat)(int, const char*, struct stat*, int);
  int (*statx)(int, const char*, int, unsigned, struct statx*);
  int (*xstat)(int, const char*, struct stat*);
  int (*lxstat)(int, const char*, struct stat*);
  int (*fxstatat)(int, int, const char*, struct stat*, int);
  int (*access)(const char*, int);
  int (*faccessat)(int, const char*, int, int);
};

PortMap g_map;
int g_mapping_port[kMaxMappings];  // mapping -> port index
Real g_real{};
std::atomic<int> g_state{0};  // 0 = not set up, 1 = setting up, 2 = ready (active or passing through)
bool g_active = false;        // a valid map with at least one live port
std::atomic<bool> g_said_fd_limit{false};

template <typename F>
void resolve(F& f, const char* name) noexcept {
  f = reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

void say(const char* a, const char* b = "", const char* c = "", const char* d = "") noexcept {
  const int saved = errno;
  for (const char* part : {"doppel-run shim: ", a, b, c, d, "\n"}) {
    [[maybe_unused]] const ssize_t n = ::write(2, part, strlen(part));
  }
  errno = saved;
}

void resolve_all() noexcept {
  resolve(g_real.open, "open");
  resolve(g_real.open64, "open64");
  resolve(g_real.openat, "openat");
  resolve(g_real.openat64, "openat64");
  resolve(g_real.open_2, "__open_2");
  resolve(g_real.open64_2, "__open64_2");
  resolve(g_real.openat_2, "__openat_2");
  resolve(g_real.openat64_2, "__openat64_2");
  resolve(g_real.fopen, "fopen");
  resolve(g_real.fopen64, "fopen64");
  resolve(g_real.fclose, "fclose");
  resolve(g_real.close, "close");
  resolve(g_real.close_range, "close_range");
  resolve(g_real.closefrom, "closefrom");
  resolve(g_real.dup, "dup");
  resolve(g_real.dup2, "dup2");
  resolve(g_real.dup3, "dup3");
  resolve(g_real.fcntl, "fcntl");
  resolve(g_real.fcntl64, "fcntl64");
  resolve(g_real.ioctl, "ioctl");
  resolve(g_real.tcflush, "tcflush");
  resolve(g_real.tcsetattr, "tcsetattr");
  resolve(g_real.stat, "stat");
  resolve(g_real.lstat, "lstat");
  resolve(g_real.fstatat, "fstatat");
  resolve(g_real.statx, "statx");
  resolve(g_real.xstat, "__xstat");
  resolve(g_real.lxstat, "__lxstat");
  resolve(g_real.fxstatat, "__fxstatat");
  resolve(g_real.access, "access");
  resolve(g_real.faccessat, "faccessat");
}

int trailing_number(std::string_view name) noexcept {
  std::size_t first = name.size();
  while (first > 0 && name[first - 1] >= '0' && name[first - 1] <= '9') --first;
  int n = 0;
  for (std::size_t i = first; i < name.size() && n < 100000; ++i) n = n * 10 + (name[i] - '0');
  return n;
}

// Checks one mapping's link: a symlink to a character device (Doppel's pty). Fills `port`.
bool check_link(const Mapping& mapping, Port& port) noexcept {
  const char* link = mapping.link.data();
  struct stat st {};
  if (g_real.lstat(link, &st) != 0) {
    say(link, " (for ", mapping.device.data(), ") does not exist: is doppel running? That device passes through");
    return false;
  }
  const ssize_t n = ::readlink(link, port.pts, sizeof(port.pts) - 1);
  if (n <= 0 || g_real.stat(link, &st) != 0 || !S_ISCHR(st.st_mode)) {
    say(link, " (for ", mapping.device.data(), ") is not a link to a live pty: is doppel running? That device passes through");
    port.pts[0] = '\0';
    return false;
  }
  port.pts[n] = '\0';
  return true;
}

// Maps <link>.received if doppel keeps one; without it (an older doppel) writes pass as before.
void map_received(Port& port) noexcept {
  char path[kMaxPathBytes + 16];
  snprintf(path, sizeof(path), "%s%s", port.link, kHandoverSuffix);
  const int fd = g_real.open(path, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    say(path, " is missing: writes to ", port.link, " return before doppel has the bytes (an older doppel?)");
    return;
  }
  struct stat st {};
  void* p = MAP_FAILED;
  if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size >= static_cast<off_t>(sizeof(uint64_t))) {
    p = ::mmap(nullptr, sizeof(uint64_t), PROT_READ, MAP_SHARED, fd, 0);
  }
  g_real.close(fd);
  if (p == MAP_FAILED) {
    say(path, " is not doppel's hand-over counter: writes are not waited for");
    return;
  }
  port.received = static_cast<const std::atomic<uint64_t>*>(p);
  port.expected.store(port.received->load(std::memory_order_acquire), std::memory_order_relaxed);
}

void set_up() noexcept {
  resolve_all();
  const char* spec = ::getenv(kPortsVariable);
  if (spec == nullptr) {
    say(kPortsVariable, " is not set (start programs with doppel-run); passing everything through");
    return;
  }
  if (!g_map.parse(spec)) {
    say(kPortsVariable, ": ", g_map.error(), "; passing everything through");
    return;
  }
  std::size_t ports = 0;
  for (std::size_t m = 0; m < g_map.size(); ++m) {
    const Mapping& mapping = g_map[m];
    g_mapping_port[m] = -1;
    for (std::size_t p = 0; p < ports; ++p) {
      if (strcmp(port_slot(p).link, mapping.link.data()) == 0) g_mapping_port[m] = static_cast<int>(p);
    }
    if (g_mapping_port[m] < 0) {
      Port& port = port_slot(ports);
      if (!check_link(mapping, port)) continue;
      port.link = mapping.link.data();
      snprintf(port.latency_file, sizeof(port.latency_file), "%s.latency_timer", port.link);
      map_received(port);
      g_mapping_port[m] = static_cast<int>(ports++);
    }
    // The first ttyUSB<n> mapped to a port names its sysfs latency timer and its line.
    Port& port = port_slot(static_cast<std::size_t>(g_mapping_port[m]));
    const std::string_view device = base_name(mapping.device.data());
    if (port.tty[0] == '\0' && device.size() > 6 && std::string_view(device.data(), 6) == "ttyUSB") {
      memcpy(port.tty, device.data(), device.size());
      port.tty[device.size()] = '\0';
      port.line = trailing_number(device);
    }
  }
  set_port_count(ports);
  g_active = ports > 0;
}

// True once set up (always after the constructor). A call that comes in while another thread sets
// up passes through.
bool ready() noexcept {
  int state = g_state.load(std::memory_order_acquire);
  if (state == 2) return true;
  int expected = 0;
  if (state == 0 && g_state.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) {
    const int saved = errno;
    set_up();
    errno = saved;
    g_state.store(2, std::memory_order_release);
    return true;
  }
  return g_state.load(std::memory_order_acquire) == 2;
}

// libc's `name` even when called before set-up finished (from another thread's set-up).
template <typename F>
F real(F Real::*member, const char* name) noexcept {
  F f = g_real.*member;
  if (f == nullptr) resolve(f, name);
  return f;
}

// Where an open of `path` really goes: the path to pass to libc and Doppel's port index (-1 = not one).
struct Target {
  const char* path;
  int port;
  bool device;  // `path` was a mapped device path (stat it as the device, not as a symlink)
};

Target target_of(const char* path) noexcept {
  if (path == nullptr || path[0] != '/' || !ready() || !g_active) return {path, -1, false};
  const std::string_view p(path);
  const int m = g_map.find_device(p);
  if (m >= 0 && g_mapping_port[m] >= 0) return {port_slot(static_cast<std::size_t>(g_mapping_port[m])).link, g_mapping_port[m], true};
  for (std::size_t i = 0; i < port_count(); ++i) {
    if (p == port_slot(i).link || p == port_slot(i).pts) return {path, static_cast<int>(i), false};
  }
  const std::string_view tty = latency_timer_tty(p);
  if (!tty.empty()) {
    for (std::size_t i = 0; i < port_count(); ++i) {
      if (tty == port_slot(i).tty) return {port_slot(i).latency_file, -1, true};
    }
  }
  return {path, -1, false};
}

int opened(int fd, const Target& target) noexcept {
  if (fd >= 0 && target.port >= 0) {
    port_slot(static_cast<std::size_t>(target.port)).dtr_rts.store(TIOCM_DTR | TIOCM_RTS, std::memory_order_relaxed);  // tty_port_open raises them
    if (!track(fd, target.port) && !g_said_fd_limit.exchange(true)) {
      say("a Doppel port opened as a descriptor above 4095 passes through untouched");
    }
  } else {
    untrack(fd);  // a number freed behind the table's back (e.g. by a raw close) is not Doppel's any more
  }
  return fd;
}

bool needs_mode(int flags) noexcept { return (flags & O_CREAT) != 0 || (flags & O_TMPFILE) == O_TMPFILE; }

FtdiSettings settings_of(const Port& port) noexcept {
  FtdiSettings s;
  s.flags = port.flags.load(std::memory_order_relaxed);
  s.custom_divisor = port.custom_divisor.load(std::memory_order_relaxed);
  s.close_delay = port.close_delay.load(std::memory_order_relaxed);
  s.closing_wait = port.closing_wait.load(std::memory_order_relaxed);
  s.dtr_rts = port.dtr_rts.load(std::memory_order_relaxed);
  return s;
}

void store(Port& port, const FtdiSettings& s) noexcept {
  port.flags.store(s.flags, std::memory_order_relaxed);
  port.custom_divisor.store(s.custom_divisor, std::memory_order_relaxed);
  port.close_delay.store(s.close_delay, std::memory_order_relaxed);
  port.closing_wait.store(s.closing_wait, std::memory_order_relaxed);
  port.dtr_rts.store(s.dtr_rts, std::memory_order_relaxed);
}

// The latency timer in the port's file, 0 when unreadable.
int read_latency_ms(const Port& port) noexcept {
  char text[32];
  const int fd = g_real.open(port.latency_file, O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return 0;
  const ssize_t n = ::read(fd, text, sizeof(text));
  g_real.close(fd);
  if (n <= 0) return 0;
  const auto value = parse_latency_timer_ms(std::string_view(text, static_cast<std::size_t>(n)));
  return value ? static_cast<int>(*value) : 0;
}

void write_latency_ms(const Port& port, int latency_ms) noexcept {
  char text[16];
  const int n = snprintf(text, sizeof(text), "%d\n", latency_ms);
  const int fd = g_real.open(port.latency_file, O_WRONLY | O_TRUNC | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    say("cannot write ", port.latency_file, ": ", strerror(errno));
    return;
  }
  [[maybe_unused]] const ssize_t written = ::write(fd, text, static_cast<std::size_t>(n));
  g_real.close(fd);
}

// After the program set the termios of `fd`: with a custom divisor, a requested 38400 means the
// custom rate (ftdi_sio get_ftdi_divisor), which the line then carries for Doppel's wire model.
void apply_custom_rate(int fd, const Port& port) noexcept {
  const FtdiSettings s = settings_of(port);
  const uint32_t termios_bps = line_rate_bps(g_real.ioctl, fd);
  const uint32_t rate_bps = ftdi_line_rate_bps(s, termios_bps);
  if (rate_bps != termios_bps) {
    const int saved = errno;
    set_line_rate_bps(g_real.ioctl, fd, rate_bps);
    errno = saved;
  }
}

int fail(int error) noexcept {
  errno = error;
  return -1;
}

int serial_ioctl(int fd, Port& port, unsigned long request, void* arg) noexcept {
  switch (request) {
    case TIOCGSERIAL: {
      if (arg == nullptr) return fail(EFAULT);
      const serial_struct out = ftdi_get_serial(settings_of(port), port.line);
      memcpy(arg, &out, sizeof(out));
      return 0;
    }
    case TIOCSSERIAL: {
      if (arg == nullptr) return fail(EFAULT);
      serial_struct in;
      memcpy(&in, arg, sizeof(in));
      FtdiSettings s = settings_of(port);
      const SetSerialResult result = ftdi_set_serial(s, in, ::geteuid() == 0);
      if (result.error != 0) return fail(result.error);
      store(port, s);
      if (result.latency_changed) {
        if ((s.flags & ASYNC_LOW_LATENCY) != 0) {
          port.latency_before_low_ms.store(read_latency_ms(port), std::memory_order_relaxed);
          write_latency_ms(port, 1);
        } else if (const int before = port.latency_before_low_ms.load(std::memory_order_relaxed); before > 0) {
          write_latency_ms(port, before);
        }
      }
      if (result.speed_changed) apply_custom_rate(fd, port);
      return 0;
    }
    case TIOCMGET:
      if (arg == nullptr) return fail(EFAULT);
      *static_cast<int*>(arg) = ftdi_modem_lines(settings_of(port));
      return 0;
    case TIOCMSET:
    case TIOCMBIS:
    case TIOCMBIC: {
      if (arg == nullptr) return fail(EFAULT);
      const unsigned value = *static_cast<const unsigned*>(arg);
      FtdiSettings s = settings_of(port);
      if (request == TIOCMSET) ftdi_update_modem_lines(s, value, ~value);
      if (request == TIOCMBIS) ftdi_update_modem_lines(s, value, 0);
      if (request == TIOCMBIC) ftdi_update_modem_lines(s, 0, value);
      port.dtr_rts.store(s.dtr_rts, std::memory_order_relaxed);
      return 0;
    }
    case TIOCGRS485:
    case TIOCSRS485:
      return fail(ENOTTY);
    case TCFLSH: {
      // A USB adapter has already sent what was written: TCOFLUSH keeps it, TCIOFLUSH flushes input.
      const auto queue = reinterpret_cast<intptr_t>(arg);
      if (queue == TCOFLUSH) return 0;
      return g_real.ioctl(fd, TCFLSH, queue == TCIOFLUSH ? static_cast<intptr_t>(TCIFLUSH) : queue);
    }
    case TCSETS:
    case TCSETSW:
    case TCSETSF: {
      const int r = g_real.ioctl(fd, request, arg);
      if (r == 0) apply_custom_rate(fd, port);
      return r;
    }
    default:
      return g_real.ioctl(fd, request, arg);
  }
}

// A camera's sysfs uevent file (v4l2_shim.cpp) or `path` itself.
const char* sys_path(const char* path) noexcept {
  const char* redirect = v4l2_sys_redirect(path);
  return redirect != nullptr ? redirect : path;
}

int open_at(int (*fn)(int, const char*, int, ...), int dirfd, const char* path, int flags, mode_t mode) noexcept {
  if (const int fd = v4l2_open(path, flags); fd != kNotCamera) return fd;
  const Target t = target_of(sys_path(path));
  return opened(fn(dirfd, t.path, flags, mode), t);
}

int open_path(int (*fn)(const char*, int, ...), const char* path, int flags, mode_t mode) noexcept {
  if (const int fd = v4l2_open(path, flags); fd != kNotCamera) return fd;
  const Target t = target_of(sys_path(path));
  return opened(fn(t.path, flags, mode), t);
}

__attribute__((constructor)) void load() noexcept { ready(); }

}  // namespace

}  // namespace doppel::shim

using namespace doppel::shim;

#define SHIM_MODE(flags)                        \
  mode_t mode = 0;                              \
  if (needs_mode(flags)) {                      \
    va_list args;                               \
    va_start(args, flags);                      \
    mode = static_cast<mode_t>(va_arg(args, int)); \
    va_end(args);                               \
  }

SHIM_EXPORT int open(const char* path, int flags, ...) {
  SHIM_MODE(flags);
  return open_path(real(&Real::open, "open"), path, flags, mode);
}
SHIM_EXPORT int open64(const char* path, int flags, ...) {
  SHIM_MODE(flags);
  return open_path(real(&Real::open64, "open64"), path, flags, mode);
}
SHIM_EXPORT int openat(int dirfd, const char* path, int flags, ...) {
  SHIM_MODE(flags);
  return open_at(real(&Real::openat, "openat"), dirfd, path, flags, mode);
}
SHIM_EXPORT int openat64(int dirfd, const char* path, int flags, ...) {
  SHIM_MODE(flags);
  return open_at(real(&Real::openat64, "openat64"), dirfd, path, flags, mode);
}
SHIM_EXPORT int __open_2(const char* path, int flags) {
  if (const int fd = v4l2_open(path, flags); fd != kNotCamera) return fd;
  const Target t = target_of(sys_path(path));
  return opened(real(&Real::open_2, "__open_2")(t.path, flags), t);
}
SHIM_EXPORT int __open64_2(const char* path, int flags) {
  if (const int fd = v4l2_open(path, flags); fd != kNotCamera) return fd;
  const Target t = target_of(sys_path(path));
  return opened(real(&Real::open64_2, "__open64_2")(t.path, flags), t);
}
SHIM_EXPORT int __openat_2(int dirfd, const char* path, int flags) {
  if (const int fd = v4l2_open(path, flags); fd != kNotCamera) return fd;
  const Target t = target_of(sys_path(path));
  return opened(real(&Real::openat_2, "__openat_2")(dirfd, t.path, flags), t);
}
SHIM_EXPORT int __openat64_2(int dirfd, const char* path, int flags) {
  if (const int fd = v4l2_open(path, flags); fd != kNotCamera) return fd;
  const Target t = target_of(sys_path(path));
  return opened(real(&Real::openat64_2, "__openat64_2")(dirfd, t.path, flags), t);
}

SHIM_EXPORT FILE* fopen(const char* path, const char* mode) {
  const Target t = target_of(sys_path(path));
  FILE* file = real(&Real::fopen, "fopen")(t.path, mode);
  if (file != nullptr) opened(fileno(file), t);
  return file;
}
SHIM_EXPORT FILE* fopen64(const char* path, const char* mode) {
  const Target t = target_of(sys_path(path));
  FILE* file = real(&Real::fopen64, "fopen64")(t.path, mode);
  if (file != nullptr) opened(fileno(file), t);
  return file;
}
SHIM_EXPORT int fclose(FILE* file) {
  if (file != nullptr) untrack(fileno(file));
  return real(&Real::fclose, "fclose")(file);
}

SHIM_EXPORT int close(int fd) {
  if (v4l2_fd(fd)) return v4l2_close(fd);
  lockstep_closing(fd);
  untrack(fd);
  return real(&Real::close, "close")(fd);
}
SHIM_EXPORT int close_range(unsigned first, unsigned last, int flags) noexcept {
  if ((flags & CLOSE_RANGE_CLOEXEC) == 0) {
    for (unsigned fd = first; fd <= last && fd < static_cast<unsigned>(kMaxFds); ++fd) untrack(static_cast<int>(fd));
  }
  return real(&Real::close_range, "close_range")(first, last, flags);
}
SHIM_EXPORT void closefrom(int first) noexcept {
  for (int fd = first < 0 ? 0 : first; fd < kMaxFds; ++fd) untrack(fd);
  real(&Real::closefrom, "closefrom")(first);
}
SHIM_EXPORT int dup(int fd) noexcept {
  const int copy = real(&Real::dup, "dup")(fd);
  if (copy >= 0) copy_fd(fd, copy);
  return copy;
}
SHIM_EXPORT int dup2(int fd, int to) noexcept {
  const int copy = real(&Real::dup2, "dup2")(fd, to);
  if (copy >= 0) copy_fd(fd, copy);
  return copy;
}
SHIM_EXPORT int dup3(int fd, int to, int flags) noexcept {
  const int copy = real(&Real::dup3, "dup3")(fd, to, flags);
  if (copy >= 0) copy_fd(fd, copy);
  return copy;
}

static int shim_fcntl(int (*fn)(int, int, ...), int fd, int cmd, void* arg) noexcept {
  const int r = fn(fd, cmd, arg);
  if (r >= 0 && (cmd == F_DUPFD || cmd == F_DUPFD_CLOEXEC)) copy_fd(fd, r);
  return r;
}
SHIM_EXPORT int fcntl(int fd, int cmd, ...) {
  va_list args;
  va_start(args, cmd);
  void* arg = va_arg(args, void*);
  va_end(args);
  return shim_fcntl(real(&Real::fcntl, "fcntl"), fd, cmd, arg);
}
SHIM_EXPORT int fcntl64(int fd, int cmd, ...) {
  va_list args;
  va_start(args, cmd);
  void* arg = va_arg(args, void*);
  va_end(args);
  return shim_fcntl(real(&Real::fcntl64, "fcntl64"), fd, cmd, arg);
}

SHIM_EXPORT int ioctl(int fd, unsigned long request, ...) noexcept {
  va_list args;
  va_start(args, request);
  void* arg = va_arg(args, void*);
  va_end(args);
  if (v4l2_fd(fd)) return v4l2_ioctl(fd, request, arg);
  if (Port* port = port_of_fd(fd)) {
    if (request != TCFLSH) return serial_ioctl(fd, *port, request, arg);
    const int queue = static_cast<int>(reinterpret_cast<intptr_t>(arg));
    lockstep_flushing(fd, queue, false);
    const int r = serial_ioctl(fd, *port, request, arg);
    lockstep_flushing(fd, queue, true);
    return r;
  }
  return real(&Real::ioctl, "ioctl")(fd, request, arg);
}

// glibc's tcflush and tcsetattr call ioctl inside libc, where the ioctl above cannot see them.
SHIM_EXPORT int tcflush(int fd, int queue) noexcept {
  if (Port* port = port_of_fd(fd)) {
    lockstep_flushing(fd, queue, false);
    const int r = serial_ioctl(fd, *port, TCFLSH, reinterpret_cast<void*>(static_cast<intptr_t>(queue)));
    lockstep_flushing(fd, queue, true);
    return r;
  }
  return real(&Real::tcflush, "tcflush")(fd, queue);
}
SHIM_EXPORT int tcsetattr(int fd, int when, const struct termios* termios) noexcept {
  const int r = real(&Real::tcsetattr, "tcsetattr")(fd, when, termios);
  if (r == 0) {
    if (const Port* port = port_of_fd(fd)) apply_custom_rate(fd, *port);
  }
  return r;
}

SHIM_EXPORT int stat(const char* path, struct stat* buf) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, buf);
  return real(&Real::stat, "stat")(target_of(path).path, buf);
}
SHIM_EXPORT int stat64(const char* path, struct stat64* buf) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, reinterpret_cast<struct stat*>(buf));
  return real(&Real::stat, "stat")(target_of(path).path, reinterpret_cast<struct stat*>(buf));
}
// A mapped device is a character device, as /dev/ttyUSB0 is: follow the link for it.
SHIM_EXPORT int lstat(const char* path, struct stat* buf) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, buf);
  const Target t = target_of(sys_path(path));
  return t.device ? real(&Real::stat, "stat")(t.path, buf) : real(&Real::lstat, "lstat")(path, buf);
}
SHIM_EXPORT int lstat64(const char* path, struct stat64* buf) noexcept {
  return lstat(path, reinterpret_cast<struct stat*>(buf));
}
SHIM_EXPORT int fstatat(int dirfd, const char* path, struct stat* buf, int flags) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, buf);
  if (path[0] == '\0' && (flags & AT_EMPTY_PATH) != 0 && v4l2_fd(dirfd)) return v4l2_stat_fd(dirfd, buf);
  const Target t = target_of(sys_path(path));
  return real(&Real::fstatat, "fstatat")(dirfd, t.path, buf, t.device ? flags & ~AT_SYMLINK_NOFOLLOW : flags);
}
SHIM_EXPORT int fstatat64(int dirfd, const char* path, struct stat64* buf, int flags) noexcept {
  return fstatat(dirfd, path, reinterpret_cast<struct stat*>(buf), flags);
}
SHIM_EXPORT int statx(int dirfd, const char* path, int flags, unsigned mask, struct statx* buf) noexcept {
  if (v4l2_device_path(path)) return v4l2_statx(path, buf);
  const Target t = target_of(sys_path(path));
  return real(&Real::statx, "statx")(dirfd, t.path, t.device ? flags & ~AT_SYMLINK_NOFOLLOW : flags, mask, buf);
}
// The stat entry points of programs built against glibc before 2.33.
SHIM_EXPORT int __xstat(int version, const char* path, struct stat* buf) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, buf);
  return real(&Real::xstat, "__xstat")(version, target_of(path).path, buf);
}
SHIM_EXPORT int __xstat64(int version, const char* path, struct stat64* buf) noexcept {
  return __xstat(version, path, reinterpret_cast<struct stat*>(buf));
}
SHIM_EXPORT int __lxstat(int version, const char* path, struct stat* buf) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, buf);
  const Target t = target_of(sys_path(path));
  return t.device ? real(&Real::xstat, "__xstat")(version, t.path, buf) : real(&Real::lxstat, "__lxstat")(version, path, buf);
}
SHIM_EXPORT int __lxstat64(int version, const char* path, struct stat64* buf) noexcept {
  return __lxstat(version, path, reinterpret_cast<struct stat*>(buf));
}
SHIM_EXPORT int __fxstatat(int version, int dirfd, const char* path, struct stat* buf, int flags) noexcept {
  if (v4l2_device_path(path)) return v4l2_stat(path, buf);
  const Target t = target_of(sys_path(path));
  return real(&Real::fxstatat, "__fxstatat")(version, dirfd, t.path, buf, t.device ? flags & ~AT_SYMLINK_NOFOLLOW : flags);
}
SHIM_EXPORT int __fxstatat64(int version, int dirfd, const char* path, struct stat64* buf, int flags) noexcept {
  return __fxstatat(version, dirfd, path, reinterpret_cast<struct stat*>(buf), flags);
}
SHIM_EXPORT int access(const char* path, int mode) noexcept {
  if (v4l2_device_path(path)) return 0;
  return real(&Real::access, "access")(target_of(path).path, mode);
}
SHIM_EXPORT int faccessat(int dirfd, const char* path, int mode, int flags) noexcept {
  if (v4l2_device_path(path)) return 0;
  return real(&Real::faccessat, "faccessat")(dirfd, target_of(path).path, mode, flags);
}

// A camera descriptor stats as its V4L2 device node does.
SHIM_EXPORT int fstat(int fd, struct stat* buf) noexcept {
  if (v4l2_fd(fd)) return v4l2_stat_fd(fd, buf);
  return static_cast<int>(syscall(SYS_fstat, fd, buf));
}
SHIM_EXPORT int fstat64(int fd, struct stat64* buf) noexcept { return fstat(fd, reinterpret_cast<struct stat*>(buf)); }
SHIM_EXPORT int __fxstat(int version, int fd, struct stat* buf) noexcept {
  (void)version;
  return fstat(fd, buf);
}
SHIM_EXPORT int __fxstat64(int version, int fd, struct stat64* buf) noexcept {
  (void)version;
  return fstat(fd, reinterpret_cast<struct stat*>(buf));
}
