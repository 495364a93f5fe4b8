#include "shim/port_map.h"

#include <cstdio>
#include <cstring>

namespace doppel::shim {
namespace {

// string_view::substr without its bounds check (which throws, and the preload library has no C++
// runtime): `first` is in range at every call below.
std::string_view part(std::string_view text, std::size_t first, std::size_t count = std::string_view::npos) noexcept {
  return std::string_view(text.data() + first, count < text.size() - first ? count : text.size() - first);
}

}  // namespace

bool PortMap::fail(const char* format, std::size_t entry, std::string_view text) noexcept {
  size_ = 0;
  const int shown = static_cast<int>(text.size() > 80 ? 80 : text.size());
  std::snprintf(error_.data(), error_.size(), format, entry, shown, text.data());
  return false;
}

bool PortMap::parse(std::string_view spec) noexcept {
  size_ = 0;
  error_[0] = '\0';
  if (spec.empty()) {
    std::snprintf(error_.data(), error_.size(), "%s is empty", kPortsVariable);
    return false;
  }
  std::size_t entry = 0;
  while (true) {
    ++entry;
    const std::size_t end = spec.find(':');
    const std::string_view item = part(spec, 0, end);
    const std::size_t equals = item.find('=');
    if (equals == std::string_view::npos) return fail("entry %zu '%.*s' is not DEVICE=LINK", entry, item);
    const std::string_view device = part(item, 0, equals);
    const std::string_view link = part(item, equals + 1);
    if (device.empty() || device[0] != '/') return fail("entry %zu '%.*s': the device is not an absolute path", entry, item);
    if (link.empty() || link[0] != '/') return fail("entry %zu '%.*s': the link is not an absolute path", entry, item);
    if (device.size() >= kMaxPathBytes || link.size() >= kMaxPathBytes) {
      return fail("entry %zu '%.*s': a path is longer than 255 bytes", entry, item);
    }
    if (device.find('\0') != std::string_view::npos || link.find('\0') != std::string_view::npos) {
      return fail("entry %zu '%.*s': a path holds a NUL byte", entry, item);
    }
    if (find_device(device) >= 0) return fail("entry %zu '%.*s': the device is mapped twice", entry, item);
    if (size_ == kMaxMappings) return fail("entry %zu '%.*s': more than 32 mappings", entry, item);
    Mapping& mapping = mappings_[size_];
    std::memcpy(mapping.device.data(), device.data(), device.size());
    mapping.device[device.size()] = '\0';
    std::memcpy(mapping.link.data(), link.data(), link.size());
    mapping.link[link.size()] = '\0';
    ++size_;
    if (end == std::string_view::npos) return true;
    spec.remove_prefix(end + 1);
  }
}

int PortMap::find_device(std::string_view path) const noexcept {
  for (std::size_t i = 0; i < size_; ++i) {
    if (path == std::string_view(mappings_[i].device.data())) return static_cast<int>(i);
  }
  return -1;
}

std::string_view base_name(std::string_view path) noexcept {
  const std::size_t slash = path.rfind('/');
  return slash == std::string_view::npos ? path : part(path, slash + 1);
}

std::string_view latency_timer_tty(std::string_view path) noexcept {
  struct Form {
    std::string_view prefix, suffix;
  };
  static constexpr Form kForms[] = {{"/sys/bus/usb-serial/devices/", "/latency_timer"},
                                    {"/sys/class/tty/", "/device/latency_timer"}};
  for (const Form& form : kForms) {
    if (path.size() <= form.prefix.size() + form.suffix.size()) continue;
    if (part(path, 0, form.prefix.size()) != form.prefix) continue;
    if (part(path, path.size() - form.suffix.size()) != form.suffix) continue;
    const std::string_view tty = part(path, form.prefix.size(), path.size() - form.prefix.size() - form.suffix.size());
    if (tty.find('/') == std::string_view::npos) return tty;
  }
  return {};
}

}  // namespace doppel::shim
