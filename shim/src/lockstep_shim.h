#pragma once
// What the serial-port part of the shim (shim.cpp) tells its lockstep part (lockstep_shim.cpp), one
// way: the lockstep part calls nothing of shim.cpp, and finds ports through the port table
// (port_table.h) both use.

namespace doppel::shim {

// `fd` is about to be closed; input of a bus `fd` is about to be flushed (done = false) or was
// flushed (done = true). No-ops without lockstep.
void lockstep_closing(int fd) noexcept;
void lockstep_flushing(int fd, int queue, bool done) noexcept;

}  // namespace doppel::shim
