#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>

#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_posh/iceoryx_posh_types.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "process.h"
#include "roudi/host.h"

namespace doppel::roudi {

namespace detail {
std::atomic<bool> g_host_alive{false};
std::atomic<bool> g_client_runtime{false};
}  // namespace detail

bool running() {
  const std::string path =
      std::string(iox::platform::IOX_LOCK_FILE_PATH_PREFIX) + iox::roudi::ROUDI_LOCK_NAME + ".lock";
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;  // never created: no RouDi has run since boot
  const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
  ::close(fd);  // also drops the lock if we just took it
  return held;
}

void set_log_level(bool verbose) {
  // kHideLogLevel: no "Log level set to" line either.
  iox::log::LogManager::GetLogManager().SetDefaultLogLevel(
      verbose ? iox::log::LogLevel::kInfo : iox::log::LogLevel::kError,
      verbose ? iox::log::LogLevelOutput::kDisplayLogLevel : iox::log::LogLevelOutput::kHideLogLevel);
}

bool client_registered() noexcept { return detail::g_client_runtime.load(); }

void register_client(const std::string& runtime_name) {
  if (detail::g_host_alive.load() || detail::g_client_runtime.load()) return;
  iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, runtime_name.c_str()));
  detail::g_client_runtime = true;
}

}  // namespace doppel::roudi
