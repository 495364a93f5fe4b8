// The camera part of libdoppel_shim.so (docs/shim.md, "Cameras"): recognises the camera device
// paths of DOPPEL_SHIM_CAMERAS, loads libdoppel_v4l2.so on the first such open and hands it the
// descriptors it returned. Libc only, like the rest of the shim; the map is parsed once into fixed
// arrays.
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>

#include "lockstep_shim.h"
#include "v4l2_api.h"
#include "v4l2_shim.h"

#define SHIM_EXPORT extern "C" __attribute__((visibility("default")))

namespace doppel::shim {
namespace {

constexpr int kMaxFds = 4096;
constexpr int kMaxCameras = 16;
constexpr size_t kMaxName = 128;

struct CameraMapping {
  char device[kMaxName] = {};
  char camera[kMaxName] = {};
};

CameraMapping g_cameras[kMaxCameras];
int g_camera_count = 0;
std::atomic<int> g_map_state{0};  // 0 unparsed, 1 parsing, 2 parsed
std::atomic<bool> g_fd_camera[kMaxFds];
std::atomic<int> g_fd_events[kMaxFds];  // the module's event descriptor + 1 (0: none yet)
std::atomic<const DoppelV4l2Api*> g_api{nullptr};
std::atomic<bool> g_module_failed{false};
std::atomic<bool> g_exit_handler{false};

void say(const char* a, const char* b = "", const char* c = "") noexcept {
  const int saved = errno;
  for (const char* part : {"doppel-run shim: ", a, b, c, "\n"}) {
    [[maybe_unused]] const long n = syscall(SYS_write, 2, part, strlen(part));
  }
  errno = saved;
}

// "DEVICE=CAMERA[:DEVICE=CAMERA]..."; a bad entry is named and skipped.
void parse_map() noexcept {
  int expected = 0;
  if (!g_map_state.compare_exchange_strong(expected, 1)) {
    while (g_map_state.load() != 2) {
    }
    return;
  }
  const char* spec = getenv(kDoppelCamerasVariable);
  while (spec != nullptr && *spec != '\0' && g_camera_count < kMaxCameras) {
    const char* end = strchr(spec, ':');
    const size_t length = end == nullptr ? strlen(spec) : static_cast<size_t>(end - spec);
    const char* equals = static_cast<const char*>(memchr(spec, '=', length));
    const size_t device_length = equals == nullptr ? 0 : static_cast<size_t>(equals - spec);
    const size_t camera_length = equals == nullptr ? 0 : length - device_length - 1;
    if (equals == nullptr || device_length == 0 || camera_length == 0 || device_length >= kMaxName ||
        camera_length >= kMaxName || spec[0] != '/') {
      say(kDoppelCamerasVariable, ": an entry is not /DEVICE=CAMERA; it is ignored");
    } else {
      CameraMapping& m = g_cameras[g_camera_count++];
      memcpy(m.device, spec, device_length);
      memcpy(m.camera, equals + 1, camera_length);
    }
    spec = end == nullptr ? nullptr : end + 1;
  }
  g_map_state.store(2);
}

const DoppelV4l2Api* api() noexcept {
  if (const DoppelV4l2Api* loaded = g_api.load(std::memory_order_acquire)) return loaded;
  if (g_module_failed.load()) return nullptr;
  const char* path = getenv(kDoppelV4l2ModuleVariable);
  if (path == nullptr || *path == '\0') {
    say(kDoppelV4l2ModuleVariable, " is not set (start programs with doppel-run): cameras cannot be opened");
    g_module_failed = true;
    return nullptr;
  }
  void* module = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  auto* entry = module == nullptr ? nullptr : reinterpret_cast<const DoppelV4l2Api* (*)()>(dlsym(module, "doppel_v4l2_api"));
  if (entry == nullptr) {
    say("cannot load the camera module ", path, dlerror() != nullptr ? "" : "");
    g_module_failed = true;
    return nullptr;
  }
  const DoppelV4l2Api* loaded = entry();
  if (lockstep_clock()) loaded->set_lockstep(lockstep_sim_ns, lockstep_monotonic_offset_ns());
  g_api.store(loaded, std::memory_order_release);
  return loaded;
}

void* (*real_mmap)(void*, size_t, int, int, int, off_t) = nullptr;
int (*real_munmap)(void*, size_t) = nullptr;

int mapping_of(const char* path) noexcept {
  if (path == nullptr || strncmp(path, "/dev/video", 10) != 0) return -1;
  if (g_map_state.load(std::memory_order_acquire) != 2) parse_map();
  for (int i = 0; i < g_camera_count; ++i) {
    if (strcmp(path, g_cameras[i].device) == 0) return i;
  }
  return -1;
}

unsigned minor_of(const char* device) noexcept { return static_cast<unsigned>(atoi(device + 10)); }

void fake_stat(unsigned minor, struct stat* buf) noexcept {
  memset(buf, 0, sizeof(*buf));
  buf->st_mode = S_IFCHR | 0660;
  buf->st_rdev = makedev(81, minor);  // Documentation/admin-guide/devices.txt: 81 = video4linux
  buf->st_nlink = 1;
  buf->st_blksize = 4096;
}

int g_fd_minor[kMaxFds];

// /sys/dev/char/81:<n>/uevent, which v4l-utils read to learn that a node is a video device: a
// memfd per camera holding what the kernel writes there, opened again through /proc/self/fd.
struct Uevent {
  std::atomic<int> state{0};  // 0 none, 1 making, 2 ready
  char path[48] = {};
};
Uevent g_uevents[kMaxCameras];

}  // namespace

const char* v4l2_sys_redirect(const char* path) noexcept {
  constexpr char kPrefix[] = "/sys/dev/char/81:";
  if (path == nullptr || strncmp(path, kPrefix, sizeof(kPrefix) - 1) != 0) return nullptr;
  if (g_map_state.load(std::memory_order_acquire) != 2) parse_map();
  const char* rest = path + sizeof(kPrefix) - 1;
  char* end = nullptr;
  const long minor = strtol(rest, &end, 10);
  if (end == rest || strcmp(end, "/uevent") != 0) return nullptr;
  for (int i = 0; i < g_camera_count; ++i) {
    if (static_cast<long>(minor_of(g_cameras[i].device)) != minor) continue;
    Uevent& u = g_uevents[i];
    int expected = 0;
    if (u.state.compare_exchange_strong(expected, 1)) {
      const int fd = static_cast<int>(syscall(SYS_memfd_create, "doppel-uevent", 0));
      char text[96];
      const int n = snprintf(text, sizeof(text), "MAJOR=81\nMINOR=%ld\nDEVNAME=video%ld\n", minor, minor);
      if (fd >= 0 && syscall(SYS_write, fd, text, n) == n) snprintf(u.path, sizeof(u.path), "/proc/self/fd/%d", fd);
      u.state.store(2, std::memory_order_release);
    }
    while (u.state.load(std::memory_order_acquire) != 2) {
    }
    return u.path[0] != '\0' ? u.path : nullptr;
  }
  return nullptr;
}

bool v4l2_device_path(const char* path) noexcept { return mapping_of(path) >= 0; }

int v4l2_stat(const char* path, struct stat* buf) noexcept {
  if (buf == nullptr) {
    errno = EFAULT;
    return -1;
  }
  fake_stat(minor_of(g_cameras[mapping_of(path)].device), buf);
  return 0;
}

int v4l2_statx(const char* path, struct statx* buf) noexcept {
  if (buf == nullptr) {
    errno = EFAULT;
    return -1;
  }
  memset(buf, 0, sizeof(*buf));
  buf->stx_mask = STATX_TYPE | STATX_MODE | STATX_NLINK;
  buf->stx_mode = S_IFCHR | 0660;
  buf->stx_nlink = 1;
  buf->stx_blksize = 4096;
  buf->stx_rdev_major = 81;
  buf->stx_rdev_minor = minor_of(g_cameras[mapping_of(path)].device);
  return 0;
}

int v4l2_stat_fd(int fd, struct stat* buf) noexcept {
  if (buf == nullptr) {
    errno = EFAULT;
    return -1;
  }
  fake_stat(static_cast<unsigned>(g_fd_minor[fd]), buf);
  return 0;
}

int v4l2_open(const char* path, int flags) noexcept {
  if (path == nullptr || strncmp(path, "/dev/video", 10) != 0) return kNotCamera;
  if (g_map_state.load(std::memory_order_acquire) != 2) parse_map();
  for (int i = 0; i < g_camera_count; ++i) {
    if (strcmp(path, g_cameras[i].device) != 0) continue;
    LockstepBypass bypass;  // the module's iceoryx work takes no simulation time
    const DoppelV4l2Api* a = api();
    if (a == nullptr) {
      errno = ENODEV;
      return -1;
    }
    const int fd = a->open(path, g_cameras[i].camera, flags);
    if (fd >= kMaxFds) {
      say(path, ": the descriptor is above the shim's table; closing it");
      a->close(fd);
      errno = EMFILE;
      return -1;
    }
    if (fd >= 0 && lockstep_clock() && !g_exit_handler.exchange(true)) {
      // Registered after the module's own (and iceoryx's runtime), so it runs before them: the
      // exiting thread's teardown of iceoryx (requests to RouDi) takes no simulation time.
      atexit(lockstep_bypass_for_good);
    }
    if (fd >= 0) {
      g_fd_minor[fd] = static_cast<int>(minor_of(g_cameras[i].device));
      g_fd_camera[fd].store(true, std::memory_order_release);
    }
    return fd;
  }
  return kNotCamera;
}

bool v4l2_fd(int fd) noexcept { return fd >= 0 && fd < kMaxFds && g_fd_camera[fd].load(std::memory_order_acquire); }

int v4l2_close(int fd) noexcept {
  g_fd_camera[fd].store(false, std::memory_order_release);
  g_fd_events[fd].store(0, std::memory_order_release);
  LockstepBypass bypass;
  return g_api.load()->close(fd);
}

namespace {

// A call of the module that would block (DQBUF, read on a blocking descriptor) answers EAGAIN in
// lockstep; the thread then waits for the next event of simulation time and asks again, so a
// frame is got at the simulation time doppel published it, and time passes meanwhile.
template <typename Call>
long camera_call(int fd, bool may_block, Call call) noexcept {
  const bool wait = may_block && lockstep_thread() && (fcntl(fd, F_GETFL) & O_NONBLOCK) == 0;
  for (;;) {
    long r;
    {
      LockstepBypass bypass;
      r = call();
    }
    if (!wait || r >= 0 || errno != EAGAIN) return r;
    lockstep_wait_event();
  }
}

}  // namespace

int v4l2_ioctl(int fd, unsigned long request, void* arg) noexcept {
  const DoppelV4l2Api* a = g_api.load();
  const bool may_block = request == VIDIOC_DQBUF || request == VIDIOC_DQEVENT;
  const int r = static_cast<int>(camera_call(fd, may_block, [&] { return static_cast<long>(a->ioctl(fd, request, arg)); }));
  if (r == 0 && request == VIDIOC_SUBSCRIBE_EVENT) {
    LockstepBypass bypass;
    g_fd_events[fd].store(a->event_fd(fd) + 1, std::memory_order_release);
  }
  return r;
}

int v4l2_event_fd(int fd) noexcept {
  return fd >= 0 && fd < kMaxFds ? g_fd_events[fd].load(std::memory_order_acquire) - 1 : -1;
}

ssize_t v4l2_read(int fd, void* buffer, size_t n) noexcept {
  return static_cast<ssize_t>(camera_call(fd, true, [&] { return static_cast<long>(g_api.load()->read(fd, buffer, n)); }));
}

void v4l2_pump(int fd) noexcept {
  const DoppelV4l2Api* a = g_api.load(std::memory_order_acquire);
  if (a == nullptr) return;
  LockstepBypass bypass;
  a->pump(fd);
}

}  // namespace doppel::shim

using namespace doppel::shim;

SHIM_EXPORT void* mmap(void* addr, size_t length, int prot, int flags, int fd, off_t offset) noexcept {
  if (v4l2_fd(fd)) {
    LockstepBypass bypass;
    return g_api.load()->mmap(addr, length, prot, flags, fd, offset);
  }
  if (real_mmap == nullptr) real_mmap = reinterpret_cast<void* (*)(void*, size_t, int, int, int, off_t)>(dlsym(RTLD_NEXT, "mmap"));
  return real_mmap(addr, length, prot, flags, fd, offset);
}
SHIM_EXPORT void* mmap64(void* addr, size_t length, int prot, int flags, int fd, off_t offset) noexcept {
  return mmap(addr, length, prot, flags, fd, offset);
}
SHIM_EXPORT int munmap(void* addr, size_t length) noexcept {
  if (real_munmap == nullptr) real_munmap = reinterpret_cast<int (*)(void*, size_t)>(dlsym(RTLD_NEXT, "munmap"));
  const int r = real_munmap(addr, length);
  if (r == 0) {
    if (const DoppelV4l2Api* a = g_api.load(std::memory_order_acquire)) {
      LockstepBypass bypass;
      a->unmapped(addr, length);
    }
  }
  return r;
}
