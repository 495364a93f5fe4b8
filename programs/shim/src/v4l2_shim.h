#pragma once
// Between the serial-port part of the shim (shim.cpp, lockstep_shim.cpp) and its camera part
// (v4l2_shim.cpp): the few calls that must look at a camera descriptor first. No-ops, and never a
// dlopen, for programs that open no /dev/video device.

#include <stddef.h>
#include <sys/stat.h>
#include <sys/types.h>

namespace doppel::shim {

inline constexpr int kNotCamera = -2;

// open of `path`: kNotCamera when it is not a camera device of the map, else the descriptor or -1.
int v4l2_open(const char* path, int flags) noexcept;
// True when `path` is a camera device of the map; it then stats as a V4L2 node (character device,
// major 81, minor <n> of /dev/video<n>, mode 0660) without loading anything.
bool v4l2_device_path(const char* path) noexcept;
int v4l2_stat(const char* path, struct stat* buf) noexcept;
int v4l2_statx(const char* path, struct statx* buf) noexcept;
int v4l2_stat_fd(int fd, struct stat* buf) noexcept;
// The file to open instead of `path` when it is a camera's /sys/dev/char/81:<n>/uevent, else nullptr.
const char* v4l2_sys_redirect(const char* path) noexcept;
// True when `fd` is a camera descriptor opened through v4l2_open.
bool v4l2_fd(int fd) noexcept;
int v4l2_close(int fd) noexcept;
int v4l2_ioctl(int fd, unsigned long request, void* arg) noexcept;
ssize_t v4l2_read(int fd, void* buffer, size_t n) noexcept;
// The descriptor readable while a control event waits for camera descriptor `fd` (subscribed with
// VIDIOC_SUBSCRIBE_EVENT), else -1: poll and select report it as the camera's POLLPRI.
int v4l2_event_fd(int fd) noexcept;
// Lockstep: frames published so far into the buffers of `fd`'s camera (-1: every camera). A
// no-op before the module is loaded.
void v4l2_pump(int fd) noexcept;

}  // namespace doppel::shim
