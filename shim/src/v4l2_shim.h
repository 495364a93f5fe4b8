#pragma once
// Between the serial-port part of the shim (shim.cpp, lockstep_shim.cpp) and its camera part
// (v4l2_shim.cpp): the few calls that must look at a camera descriptor first. No-ops, and never a
// dlopen, for programs that open no /dev/video device.

#include <stddef.h>
#include <sys/types.h>

namespace doppel::shim {

inline constexpr int kNotCamera = -2;

// open of `path`: kNotCamera when it is not a camera device of the map, else the descriptor or -1.
int v4l2_open(const char* path, int flags) noexcept;
// True when `fd` is a camera descriptor opened through v4l2_open.
bool v4l2_fd(int fd) noexcept;
int v4l2_close(int fd) noexcept;
int v4l2_ioctl(int fd, unsigned long request, void* arg) noexcept;
ssize_t v4l2_read(int fd, void* buffer, size_t n) noexcept;

}  // namespace doppel::shim
