#include "iox_support.h"

#include "iceoryx_posh/iceoryx_posh_types.hpp"
#include "iceoryx_posh/runtime/service_discovery.hpp"

namespace doppel::camera {
namespace detail {

iox::capro::IdString_t id(const std::string& text) { return iox::capro::IdString_t(iox::cxx::TruncateToCapacity, text); }

iox::capro::ServiceDescription service(const std::string& camera, const char* event) {
  return iox::capro::ServiceDescription(id(kServiceId), id(camera), id(event));
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
