#pragma once
// Private helpers shared by streaming.cpp and client.cpp: the one place that names iceoryx services
// and knows how this process is connected to RouDi.

#include <atomic>
#include <string>

#include "iceoryx_posh/capro/service_description.hpp"

namespace doppel::camera::detail {

inline constexpr const char kServiceId[] = "DoppelCamera";
inline constexpr const char kFramesEvent[] = "frames";
inline constexpr const char kInfoEvent[] = "info";
inline constexpr const char kSettingsEvent[] = "settings";

iox::capro::ServiceDescription service(const std::string& camera, const char* event);
// An iceoryx id string, truncated to its capacity.
iox::capro::IdString_t id(const std::string& text);

// Set while a StreamingHost exists; set for good once connect_client() registered this process.
extern std::atomic<bool> g_host_alive;
extern std::atomic<bool> g_client_runtime;

// True when another RouDi holds the machine-wide lock (/tmp/iox-unique-roudi.lock). Does not create
// the lock file.
bool roudi_lock_held();

// iceoryx's own log lines: errors only, or (verbose) from info on, with the level announcement.
void set_iceoryx_log_level(bool verbose);

// True when RouDi lists a publisher of ("DoppelCamera", camera, event).
bool service_offered(const std::string& camera, const char* event);

}  // namespace doppel::camera::detail
