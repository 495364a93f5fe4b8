#include "iox_support.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>

#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/iceoryx_posh_types.hpp"
#include "iceoryx_posh/runtime/service_discovery.hpp"

namespace doppel::camera {
namespace detail {

std::atomic<bool> g_host_alive{false};
std::atomic<bool> g_client_runtime{false};

iox::capro::IdString_t id(const std::string& text) { return iox::capro::IdString_t(iox::cxx::TruncateToCapacity, text); }

iox::capro::ServiceDescription service(const std::string& camera, const char* event) {
  return iox::capro::ServiceDescription(id(kServiceId), id(camera), id(event));
}

bool roudi_lock_held() {
  const std::string path =
      std::string(iox::platform::IOX_LOCK_FILE_PATH_PREFIX) + iox::roudi::ROUDI_LOCK_NAME + ".lock";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;  // never created: no RouDi has run since boot
  const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // also drops the lock if we just took it
  return held;
}

void set_iceoryx_log_level(bool verbose) {
  // kHideLogLevel: no "Log level set to" line either.
  iox::log::LogManager::GetLogManager().SetDefaultLogLevel(
      verbose ? iox::log::LogLevel::kInfo : iox::log::LogLevel::kError,
      verbose ? iox::log::LogLevelOutput::kDisplayLogLevel : iox::log::LogLevelOutput::kHideLogLevel);
}

bool service_offered(const std::string& camera, const char* event) {
  iox::runtime::ServiceDiscovery discovery;
  bool found = false;
  discovery.findService(
      id(kServiceId), id(camera), id(event),
      [&found](const iox::capro::ServiceDescription&) { found = true; }, iox::popo::MessagingPattern::PUB_SUB);
  return found;
}

}  // namespace detail

}  // namespace doppel::camera
