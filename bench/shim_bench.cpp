// What libdoppel_shim.so costs a program, in one run: the library is loaded with dlopen (its symbols
// come first for the calls made through its handle, as LD_PRELOAD makes them come first for a whole
// program) with a map of /dev/ttyUSB0 to a pty made here, and each call is timed through the
// library and straight through libc side by side.
// - ioctl(TIOCMGET) on the mapped port: answered by the shim vs. the system call a pty gets (ENOTTY).
// - ioctl(FIONREAD), write+read of one byte on a pipe (not Doppel's): the shim's pass-through vs. libc.
//   read and write are interposed for lockstep time (docs/lockstep.md): without DOPPEL_LOCKSTEP they
//   pass through after one load (the handle's read/write are the shim's, checked below).
// - poll() of the port and a pipe for POLLIN | POLLPRI, not waiting: interposed for lockstep time and
//   for cameras' control events; without either it passes through after one load per descriptor.
#include <benchmark/benchmark.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace {

using IoctlFn = int (*)(int, unsigned long, ...);
using OpenFn = int (*)(const char*, int, ...);
using ReadFn = ssize_t (*)(int, void*, size_t);
using WriteFn = ssize_t (*)(int, const void*, size_t);
using PollFn = int (*)(struct pollfd*, nfds_t, int);

struct Setup {
  IoctlFn shim_ioctl = nullptr;
  ReadFn shim_read = nullptr;
  WriteFn shim_write = nullptr;
  PollFn shim_poll = nullptr;
  int port_fd = -1;     // /dev/ttyUSB0 opened through the shim: Doppel's (here: a pty's)
  int pty_fd = -1;      // the same pty opened through libc: what the program has without the shim
  int pipe_fds[2] = {-1, -1};

  Setup() {
    const int master = ::posix_openpt(O_RDWR | O_NOCTTY);
    ::grantpt(master);
    ::unlockpt(master);
    const std::string dir = std::filesystem::temp_directory_path() / ("doppel-shim-bench-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string link = dir + "/ttyDXL0";
    std::filesystem::create_symlink(::ptsname(master), link);
    ::setenv("DOPPEL_SHIM_PORTS", ("/dev/ttyUSB0=" + link).c_str(), 1);
    void* shim = ::dlopen(SHIM_LIBRARY, RTLD_NOW | RTLD_LOCAL);
    if (shim == nullptr) {
      std::fprintf(stderr, "shim_bench: %s\n", ::dlerror());
      std::exit(1);
    }
    shim_ioctl = reinterpret_cast<IoctlFn>(::dlsym(shim, "ioctl"));
    shim_read = reinterpret_cast<ReadFn>(::dlsym(shim, "read"));
    shim_write = reinterpret_cast<WriteFn>(::dlsym(shim, "write"));
    shim_poll = reinterpret_cast<PollFn>(::dlsym(shim, "poll"));
    for (void* symbol : {reinterpret_cast<void*>(shim_ioctl), reinterpret_cast<void*>(shim_read),
                         reinterpret_cast<void*>(shim_write), reinterpret_cast<void*>(shim_poll)}) {
      Dl_info from{};
      ::dladdr(symbol, &from);
      if (std::string(from.dli_fname).find("doppel_shim") == std::string::npos) {
        std::fprintf(stderr, "shim_bench: expected the shim's ioctl, read, write and poll\n");
        std::exit(1);
      }
    }
    port_fd = reinterpret_cast<OpenFn>(::dlsym(shim, "open"))("/dev/ttyUSB0", O_RDWR | O_NOCTTY | O_NONBLOCK);
    pty_fd = ::open(link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK);
    int lines = 0;
    if (port_fd < 0 || pty_fd < 0 || shim_ioctl(port_fd, TIOCMGET, &lines) != 0 || ::pipe(pipe_fds) != 0) {
      std::fprintf(stderr, "shim_bench: set-up failed (port %d, pty %d)\n", port_fd, pty_fd);
      std::exit(1);
    }
    std::filesystem::remove_all(dir);
  }
};

Setup& setup() {
  static Setup instance;
  return instance;
}

void BM_Tiocmget_DoppelPortThroughShim(benchmark::State& state) {
  Setup& s = setup();
  int lines = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.shim_ioctl(s.port_fd, TIOCMGET, &lines));
  }
}
BENCHMARK(BM_Tiocmget_DoppelPortThroughShim);

void BM_Tiocmget_PtyThroughLibc(benchmark::State& state) {
  Setup& s = setup();
  int lines = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(::ioctl(s.pty_fd, TIOCMGET, &lines));  // ENOTTY: a pty has no modem lines
  }
}
BENCHMARK(BM_Tiocmget_PtyThroughLibc);

void BM_Fionread_PipeThroughShim(benchmark::State& state) {
  Setup& s = setup();
  int n = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.shim_ioctl(s.pipe_fds[0], FIONREAD, &n));
  }
}
BENCHMARK(BM_Fionread_PipeThroughShim);

void BM_Fionread_PipeThroughLibc(benchmark::State& state) {
  Setup& s = setup();
  int n = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(::ioctl(s.pipe_fds[0], FIONREAD, &n));
  }
}
BENCHMARK(BM_Fionread_PipeThroughLibc);

void BM_PipeWriteRead_ThroughShim(benchmark::State& state) {
  Setup& s = setup();
  char byte = 'x';
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.shim_write(s.pipe_fds[1], &byte, 1));
    benchmark::DoNotOptimize(s.shim_read(s.pipe_fds[0], &byte, 1));
  }
}
BENCHMARK(BM_PipeWriteRead_ThroughShim);

void BM_PipeWriteRead_ThroughLibc(benchmark::State& state) {
  Setup& s = setup();
  char byte = 'x';
  for (auto _ : state) {
    benchmark::DoNotOptimize(::write(s.pipe_fds[1], &byte, 1));
    benchmark::DoNotOptimize(::read(s.pipe_fds[0], &byte, 1));
  }
}
BENCHMARK(BM_PipeWriteRead_ThroughLibc);

void BM_PollPortAndPipe_ThroughShim(benchmark::State& state) {
  Setup& s = setup();
  for (auto _ : state) {
    struct pollfd fds[2] = {{s.port_fd, POLLIN | POLLPRI, 0}, {s.pipe_fds[0], POLLIN | POLLPRI, 0}};
    benchmark::DoNotOptimize(s.shim_poll(fds, 2, 0));
  }
}
BENCHMARK(BM_PollPortAndPipe_ThroughShim);

void BM_PollPortAndPipe_ThroughLibc(benchmark::State& state) {
  Setup& s = setup();
  for (auto _ : state) {
    struct pollfd fds[2] = {{s.pty_fd, POLLIN | POLLPRI, 0}, {s.pipe_fds[0], POLLIN | POLLPRI, 0}};
    benchmark::DoNotOptimize(::poll(fds, 2, 0));
  }
}
BENCHMARK(BM_PollPortAndPipe_ThroughLibc);

}  // namespace
