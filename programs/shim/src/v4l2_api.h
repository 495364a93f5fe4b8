#pragma once
// The C interface between the preload library (v4l2_shim.cpp, libc only) and the V4L2 device
// module libdoppel_v4l2.so (v4l2_device.cpp, C++ with iceoryx), which the shim loads with dlopen
// when a program first opens a camera device. Keeping iceoryx and libstdc++ out of the shim keeps
// programs that never open a camera exactly as they were.
//
// Every function sets errno and returns -1 (MAP_FAILED for mmap) on failure, as the system call
// it stands for does; none throws.

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

extern "C" {

struct DoppelV4l2Api {
  // Opens camera `camera` ("#<n>": the n-th camera of robot 0) for the device path `device`
  // (for messages); returns a new descriptor the program polls (an eventfd, readable while a
  // filled buffer waits).
  int (*open)(const char* device, const char* camera, int flags);
  // Forgets the descriptor's state and closes it.
  int (*close)(int fd);
  int (*ioctl)(int fd, unsigned long request, void* arg);
  void* (*mmap)(void* addr, size_t length, int prot, int flags, int fd, off_t offset);
  // A munmap of the program (any address): counts unmapped buffers for V4L2_BUF_FLAG_MAPPED.
  void (*unmapped)(void* addr, size_t length);
  ssize_t (*read)(int fd, void* buffer, size_t n);
  // Lockstep (docs/lockstep.md, "Cameras"): called once, before the first open, when the program
  // runs on doppel's simulation time. `sim_now` reads it; `monotonic_offset_ns` is what
  // CLOCK_MONOTONIC reads at simulation time 0. The module then takes frames only in pump() and in
  // the program's DQBUF and read() (no worker thread), stamps them with their simulation time, and
  // answers EAGAIN where it would block: the shim waits in simulation time and asks again.
  void (*set_lockstep)(int64_t (*sim_now)(void), int64_t monotonic_offset_ns);
  // Lockstep: moves every frame published so far from shared memory into the program's buffers
  // (or, with read(), keeps the newest), for descriptor `fd`'s camera or, with -1, every camera of
  // the process, so that the descriptor's readiness says what simulation time says.
  void (*pump)(int fd);
  // The descriptor that is readable while a control event waits for `fd` (an eventfd made at its
  // first VIDIOC_SUBSCRIBE_EVENT, closed with `fd`), -1 before that: V4L2 reports a waiting event as
  // POLLPRI, which `fd` itself cannot raise.
  int (*event_fd)(int fd);
};

// Exported by libdoppel_v4l2.so.
const DoppelV4l2Api* doppel_v4l2_api(void);
}

inline constexpr const char* kDoppelCamerasVariable = "DOPPEL_SHIM_CAMERAS";  // "DEVICE=CAMERA[:...]"
inline constexpr const char* kDoppelV4l2ModuleVariable = "DOPPEL_SHIM_V4L2";  // path of libdoppel_v4l2.so
