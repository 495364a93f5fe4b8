#pragma once
// Private helpers shared by streaming.cpp and client.cpp: the one place that names the cameras'
// iceoryx services (how this process is connected to RouDi is roudi/host.h's).

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

// True when RouDi lists a publisher of ("DoppelCamera", camera, event).
bool service_offered(const std::string& camera, const char* event);

}  // namespace doppel::camera::detail
