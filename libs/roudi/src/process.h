#pragma once
// What host.cpp and process.cpp share: how this process is connected to iceoryx.

#include <atomic>

namespace doppel::roudi::detail {

// Set while a Host exists; set for good once this process registered with a RouDi as a client.
extern std::atomic<bool> g_host_alive;
extern std::atomic<bool> g_client_runtime;

}  // namespace doppel::roudi::detail
