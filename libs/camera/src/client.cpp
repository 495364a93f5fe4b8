#include "camera/client.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <new>
#include <sstream>
#include <chrono>
#include <cstring>
#include <stdexcept>
#include <thread>

#include "concurrency/sanitizer_handover.h"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_hoofs/platform/platform_settings.hpp"
#include "iceoryx_posh/mepoo/chunk_header.hpp"
#include "iceoryx_posh/popo/untyped_publisher.hpp"
#include "iceoryx_posh/popo/untyped_subscriber.hpp"
#include "iceoryx_posh/popo/wait_set.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/service_discovery.hpp"
#include "iox_support.h"
#include "roudi/host.h"

namespace doppel::camera {
namespace {

std::string seconds_text(double s) {
  std::ostringstream out;
  out << s;
  return out.str();
}

// True when `path` names a file of this user whose flock nobody holds (taking it briefly).
bool unlocked_file_of_mine(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return errno == ENOENT;
  struct stat st {};
  const bool free = ::fstat(fd, &st) == 0 && st.st_uid == ::geteuid() && ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);  // also drops the lock if we took it
  return free;
}

}  // namespace

int remove_stale_client_files(const std::string& app_name, const std::string& directory) {
  DIR* dir = ::opendir(directory.c_str());
  if (dir == nullptr) return 0;
  const std::string prefix = app_name + "-";
  int removed = 0;
  while (const dirent* entry = ::readdir(dir)) {
    const std::string file = entry->d_name;
    if (file.rfind(prefix, 0) != 0) continue;
    const std::string pid_text = file.substr(prefix.size());
    if (pid_text.empty() || pid_text.size() > 9 ||
        !std::all_of(pid_text.begin(), pid_text.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      continue;  // also skips the .lock files: they go with their socket
    }
    const pid_t pid = static_cast<pid_t>(std::stol(pid_text));
    if (pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;  // that process still runs
    const std::string socket = directory + "/" + file;
    struct stat st {};
    if (::lstat(socket.c_str(), &st) != 0 || !S_ISSOCK(st.st_mode) || st.st_uid != ::geteuid()) continue;
    if (!unlocked_file_of_mine(socket + ".lock")) continue;
    removed += ::unlink(socket.c_str()) == 0 ? 1 : 0;
    removed += ::unlink((socket + ".lock").c_str()) == 0 ? 1 : 0;
  }
  ::closedir(dir);
  return removed;
}

bool roudi_running() { return roudi::running(); }

void connect_client(const std::string& app_name, bool verbose) {
  if (roudi::Host::exists() || roudi::client_registered()) return;
  if (!roudi::running()) {
    throw std::runtime_error("no RouDi runs on this machine: start doppel (or iox-roudi) first");
  }
  roudi::set_log_level(verbose);
  remove_stale_client_files(app_name, iox::platform::IOX_UDS_SOCKET_PATH_PREFIX);
  roudi::register_client(app_name + "-" + std::to_string(::getpid()));
}

std::vector<CameraInfo> list_cameras(double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(timeout_s));
  std::vector<std::string> names;
  {
    iox::runtime::ServiceDiscovery discovery;
    do {
      names.clear();
      discovery.findService(
          detail::id(detail::kServiceId), iox::capro::Wildcard, detail::id(detail::kInfoEvent),
          [&names](const iox::capro::ServiceDescription& s) { names.emplace_back(s.getInstanceIDString().c_str()); },
          iox::popo::MessagingPattern::PUB_SUB);
      if (!names.empty()) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    } while (std::chrono::steady_clock::now() < deadline);
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  std::vector<CameraInfo> out;
  for (const std::string& name : names) {
    iox::popo::SubscriberOptions options;
    options.queueCapacity = 1;
    options.historyRequest = 1;
    iox::popo::UntypedSubscriber sub(detail::service(name, detail::kInfoEvent), options);
    const auto until = std::max(deadline, std::chrono::steady_clock::now() + std::chrono::milliseconds(300));
    bool got = false;
    while (!got && std::chrono::steady_clock::now() < until) {
      sub.take().and_then([&](const void* payload) {
        concurrency::taken_over(payload);
        const auto* chunk = iox::mepoo::ChunkHeader::fromUserPayload(payload);
        if (chunk->userPayloadSize() >= sizeof(CameraInfo)) {
          CameraInfo info;
          std::memcpy(&info, payload, sizeof(CameraInfo));
          info.name[sizeof(info.name) - 1] = '\0';
          info.body[sizeof(info.body) - 1] = '\0';
          out.push_back(info);
          got = true;
        }
        concurrency::handing_over(payload);
        sub.release(payload);
      });
      if (!got) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  }
  return out;
}

CameraInfo set_camera_noise(const std::string& camera, const NoiseConfig& noise, double timeout_s) {
  validate(noise);
  if (!roudi::Host::exists() && !roudi::client_registered()) {
    throw std::logic_error("set_camera_noise: call connect_client() first");
  }
  if (!detail::service_offered(camera, detail::kInfoEvent)) {
    // Discovery may lag a freshly started camera: look once more after a short wait.
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    if (!detail::service_offered(camera, detail::kInfoEvent)) {
      throw std::runtime_error("no camera '" + camera + "' is published on this machine (doppel-camera list)");
    }
  }
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(timeout_s));
  static std::atomic<uint32_t> counter{0};
  NoiseRequest request;
  request.request_id = (static_cast<uint64_t>(::getpid()) << 32) | (counter.fetch_add(1) + 1);
  request.noise = noise;

  // Watch the info topic first, so that the confirmation cannot pass unseen.
  iox::popo::SubscriberOptions info_options;
  info_options.queueCapacity = 16;
  info_options.historyRequest = 1;
  iox::popo::UntypedSubscriber info(detail::service(camera, detail::kInfoEvent), info_options);
  iox::popo::PublisherOptions options;
  options.historyCapacity = 1;  // delivered even if the camera's subscription completes after publish
  iox::popo::UntypedPublisher settings(detail::service(camera, detail::kSettingsEvent), options);
  while (!settings.hasSubscribers() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!settings.hasSubscribers()) {
    throw std::runtime_error("camera '" + camera + "' did not connect to the settings topic within " +
                             seconds_text(timeout_s) + " s");
  }
  auto loaned = settings.loan(sizeof(NoiseRequest), alignof(NoiseRequest));
  if (loaned.has_error()) throw std::runtime_error("no shared memory chunk free for a settings message");
  concurrency::taken_over(loaned.value());
  new (loaned.value()) NoiseRequest(request);
  concurrency::handing_over(loaned.value());
  settings.publish(loaned.value());

  while (std::chrono::steady_clock::now() < deadline) {
    std::optional<CameraInfo> confirmed;
    for (auto taken = info.take(); !taken.has_error(); taken = info.take()) {
      const void* payload = taken.value();
      concurrency::taken_over(payload);
      if (iox::mepoo::ChunkHeader::fromUserPayload(payload)->userPayloadSize() >= sizeof(CameraInfo)) {
        CameraInfo record;
        std::memcpy(&record, payload, sizeof(CameraInfo));
        if (record.noise_request_id == request.request_id) confirmed = record;
      }
      concurrency::handing_over(payload);
      info.release(payload);
    }
    if (confirmed) {
      confirmed->name[sizeof(confirmed->name) - 1] = '\0';
      confirmed->body[sizeof(confirmed->body) - 1] = '\0';
      return *confirmed;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  throw std::runtime_error("camera '" + camera + "' did not confirm the new settings within " +
                           seconds_text(timeout_s) + " s (is doppel's simulation running?)");
}

Frame::Frame(std::shared_ptr<void> port, const FrameHeader* header) noexcept
    : port_(std::move(port)), header_(header) {}

Frame::Frame(Frame&& other) noexcept : port_(std::move(other.port_)), header_(other.header_) {
  other.header_ = nullptr;
}

Frame& Frame::operator=(Frame&& other) noexcept {
  if (this != &other) {
    release();
    port_ = std::move(other.port_);
    header_ = other.header_;
    other.header_ = nullptr;
  }
  return *this;
}

Frame::~Frame() { release(); }

void Frame::release() noexcept {
  if (port_ && header_ != nullptr) {
    concurrency::handing_over(header_);
    static_cast<iox::popo::UntypedSubscriber*>(port_.get())->release(header_);
  }
  header_ = nullptr;
  port_.reset();
}

struct FrameSubscriber::Impl {
  std::shared_ptr<iox::popo::UntypedSubscriber> sub;
  std::unique_ptr<iox::popo::WaitSet<>> waitset;
  SubscriberStats stats;
  bool have_last = false;
  uint64_t last_sequence = 0;
};

FrameSubscriber::FrameSubscriber(const std::string& camera, const SubscriberOptions& options)
    : impl_(std::make_unique<Impl>()) {
  if (!roudi::Host::exists() && !roudi::client_registered()) {
    throw std::logic_error("FrameSubscriber: call connect_client() first");
  }
  if (options.queue_capacity < 1 || options.queue_capacity > 64) {
    throw std::invalid_argument("SubscriberOptions.queue_capacity must lie in 1..64");
  }
  iox::popo::SubscriberOptions o;
  o.queueCapacity = options.queue_capacity;
  o.historyRequest = options.latest_on_connect ? 1 : 0;
  o.queueFullPolicy = iox::popo::QueueFullPolicy::DISCARD_OLDEST_DATA;
  impl_->sub = std::make_shared<iox::popo::UntypedSubscriber>(detail::service(camera, detail::kFramesEvent), o);
}

FrameSubscriber::~FrameSubscriber() {
  if (impl_->waitset) impl_->waitset->detachState(*impl_->sub, iox::popo::SubscriberState::HAS_DATA);
  impl_->waitset.reset();
}

std::optional<Frame> FrameSubscriber::try_take() noexcept {
  Impl& s = *impl_;
  for (;;) {
    auto taken = s.sub->take();
    if (taken.has_error()) return std::nullopt;
    const void* payload = taken.value();
    concurrency::taken_over(payload);
    const auto* chunk = iox::mepoo::ChunkHeader::fromUserPayload(payload);
    const auto* header = static_cast<const FrameHeader*>(payload);
    if (!frame_valid(header, chunk->userPayloadSize())) {
      ++s.stats.invalid;
      concurrency::handing_over(payload);
      s.sub->release(payload);
      continue;
    }
    if (s.have_last && header->sequence > s.last_sequence + 1) s.stats.missed += header->sequence - s.last_sequence - 1;
    s.have_last = true;
    s.last_sequence = header->sequence;
    ++s.stats.received;
    return Frame(std::static_pointer_cast<void>(s.sub), header);
  }
}

std::optional<Frame> FrameSubscriber::wait_take(double timeout_s) noexcept {
  Impl& s = *impl_;
  if (auto frame = try_take()) return frame;
  if (!s.waitset) {
    s.waitset = std::make_unique<iox::popo::WaitSet<>>();
    if (s.waitset->attachState(*s.sub, iox::popo::SubscriberState::HAS_DATA).has_error()) {
      s.waitset.reset();
      return std::nullopt;
    }
  }
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(timeout_s));
  for (;;) {
    const auto left = std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count();
    if (left <= 0.0) return try_take();
    s.waitset->timedWait(iox::units::Duration::fromNanoseconds(static_cast<uint64_t>(left * 1e9)));
    if (auto frame = try_take()) return frame;
  }
}

bool FrameSubscriber::connected() const noexcept {
  return impl_->sub->getSubscriptionState() == iox::SubscribeState::SUBSCRIBED;
}

SubscriberStats FrameSubscriber::stats() const noexcept { return impl_->stats; }

}  // namespace doppel::camera
