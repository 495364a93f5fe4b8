#include "camera/streaming.h"

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <new>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "base/monotonic_clock.h"
#include "camera/frame.h"
#include "camera/renderer.h"
#include "concurrency/sanitizer_handover.h"
#include "iceoryx_hoofs/cxx/generic_raii.hpp"
#include "iceoryx_hoofs/log/logmanager.hpp"
#include "iceoryx_hoofs/posix_wrapper/posix_access_rights.hpp"
#include "iceoryx_posh/iceoryx_posh_config.hpp"
#include "iceoryx_posh/iceoryx_posh_types.hpp"
// An internal header, on purpose: in iceoryx 2.0.3 iox::roudi::RouDi is the only way to run RouDi
// inside a process that goes on doing other work (iceoryx's own single-process example includes it
// too; the public IceOryxRouDiApp::run() blocks and takes over the signals). roudi_test.cpp pins the
// iceoryx version this was checked with, so another version fails a test before it is trusted.
#include "iceoryx_posh/internal/roudi/roudi.hpp"
#include "iceoryx_posh/internal/runtime/ipc_interface_base.hpp"
#include "iceoryx_posh/mepoo/chunk_header.hpp"
#include "iceoryx_posh/mepoo/chunk_settings.hpp"
#include "iceoryx_posh/popo/subscriber.hpp"
#include "iceoryx_posh/popo/untyped_publisher.hpp"
#include "iceoryx_posh/popo/untyped_subscriber.hpp"
#include "iceoryx_posh/roudi/iceoryx_roudi_components.hpp"
#include "iceoryx_posh/roudi/introspection_types.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/posh_runtime_single_process.hpp"
#include "iox_support.h"

namespace doppel::camera {
namespace {

constexpr uint64_t kMgmtSegmentEstimateBytes = 80ull << 20;  // RouDi's management segment (~66 MB)

uint32_t align64(uint64_t n) { return static_cast<uint32_t>((n + 63) / 64 * 64); }

// Pool payload size a frame of `payload` bytes needs: iceoryx places the 64-byte aligned payload
// after its chunk header, so a pool of exactly `payload` bytes would not fit it (and loaning a chunk
// larger than every pool aborts the process).
uint64_t pool_payload_for(uint64_t payload) {
  auto settings = iox::mepoo::ChunkSettings::create(static_cast<uint32_t>(payload), kFrameAlignment);
  if (settings.has_error()) throw std::invalid_argument("frame payload of " + std::to_string(payload) + " bytes");
  return align64(settings.value().requiredChunkSize() - sizeof(iox::mepoo::ChunkHeader));
}

// Largest chunk payload of the running RouDi's pools that this process may write to, from RouDi's
// mempool introspection topic; 0 when nothing arrives in time.
uint64_t external_max_payload(double timeout_s) {
  iox::popo::SubscriberOptions options;
  options.queueCapacity = 1;
  options.historyRequest = 1;
  iox::popo::Subscriber<iox::roudi::MemPoolIntrospectionInfoContainer> sub(iox::roudi::IntrospectionMempoolService,
                                                                          options);
  const auto group = iox::posix::PosixGroup::getGroupOfCurrentProcess().getName();
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    uint64_t best_mine = 0;
    uint64_t best_any = 0;
    bool got = false;
    sub.take().and_then([&](auto& sample) {
      got = true;
      for (const auto& segment : *sample) {
        uint64_t seg_max = 0;
        for (const auto& pool : segment.m_mempoolInfo) seg_max = std::max<uint64_t>(seg_max, pool.m_chunkPayloadSize);
        best_any = std::max(best_any, seg_max);
        if (segment.m_writerGroupName == group) best_mine = std::max(best_mine, seg_max);
      }
    });
    if (got) return best_mine > 0 ? best_mine : best_any;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return 0;
}

// Start time of process `pid` (clock ticks after boot, /proc/<pid>/stat field 22); 0 when the
// process is gone or a zombie. Together with the pid it names one process, even after pid reuse.
uint64_t process_start_ticks(uint32_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat;
  std::getline(in, stat);
  const std::size_t after_name = stat.rfind(')');
  if (after_name == std::string::npos) return 0;
  std::istringstream fields(stat.substr(after_name + 1));
  std::string state;
  fields >> state;
  if (state == "Z" || state == "X") return 0;
  std::string skipped;
  for (int field = 4; field < 22; ++field) fields >> skipped;
  uint64_t start = 0;
  fields >> start;
  return start;
}

// iceoryx 2.0's RouDi message thread writes "RouDi is ready for clients" straight to std::cout,
// bypassing its logger (roudi.cpp, processRuntimeMessages). While `active`, this points stdout at
// /dev/null; at the file-descriptor level, because that thread writes while RouDi starts and a
// stream-buffer swap would race with it. Nothing else in doppel writes to stdout meanwhile.
class QuietStdout {
 public:
  explicit QuietStdout(bool active) {
    if (!active) return;
    const int null_fd = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (null_fd < 0) return;
    std::cout.flush();
    std::fflush(stdout);
    saved_fd_ = ::fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 0);
    if (saved_fd_ >= 0) ::dup2(null_fd, STDOUT_FILENO);
    ::close(null_fd);
  }
  ~QuietStdout() {
    if (saved_fd_ < 0) return;
    std::cout.flush();
    std::fflush(stdout);
    ::dup2(saved_fd_, STDOUT_FILENO);
    ::close(saved_fd_);
  }
  QuietStdout(const QuietStdout&) = delete;
  QuietStdout& operator=(const QuietStdout&) = delete;

 private:
  int saved_fd_ = -1;
};

// RouDi inside doppel. iceoryx's own process monitoring declares a client dead when its keep-alive
// messages stop for 1.5 s, which a stopped client (SIGSTOP, a debugger, a suspended laptop) cannot
// send; the client then aborts when it continues (POPO__CHUNK_LOCKING_ERROR). So that monitoring is
// off, and this RouDi removes a client when its process is really gone: it notes the pid of every
// client that registers and looks every 500 ms whether that process still exists.
class ClientReapingRouDi final : public iox::roudi::RouDi {
 public:
  ClientReapingRouDi(iox::roudi::RouDiMemoryInterface& memory, iox::roudi::PortManager& ports)
      : RouDi(memory, ports,
              RoudiStartupParameters{iox::roudi::MonitoringMode::OFF, false,
                                     RuntimeMessagesThreadStart::DEFER_START}) {
    reaper_ = std::thread([this] { reap_until_stopped(); });
    startProcessRuntimeMessagesThread();
  }
  ~ClientReapingRouDi() override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    reaper_.join();
    shutdown();  // joins the message thread before the members it uses go
  }

 protected:
  void processMessage(const iox::runtime::IpcMessage& message, const iox::runtime::IpcMessageType& cmd,
                      const iox::RuntimeName_t& runtime_name) noexcept override {
    if (cmd == iox::runtime::IpcMessageType::REG && message.getNumberOfElements() == 6) {
      uint32_t pid = 0;
      uid_t user = 0;
      int64_t timestamp = 0;
      parseRegisterMessage(message, pid, user, timestamp);
      std::lock_guard<std::mutex> lock(mutex_);
      clients_.push_back({runtime_name, pid, process_start_ticks(pid)});
    }
    RouDi::processMessage(message, cmd, runtime_name);
  }

 private:
  struct Client {
    iox::RuntimeName_t name;
    uint32_t pid;
    uint64_t start_ticks;
  };

  void reap_until_stopped() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!wake_.wait_for(lock, std::chrono::milliseconds(500), [this] { return stop_; })) {
      std::vector<iox::RuntimeName_t> gone;
      for (auto it = clients_.begin(); it != clients_.end();) {
        if (it->start_ticks != 0 && process_start_ticks(it->pid) == it->start_ticks) {
          ++it;
          continue;
        }
        gone.push_back(it->name);
        it = clients_.erase(it);
      }
      lock.unlock();
      for (const auto& name : gone) {
        m_prcMgr->unregisterProcess(name);  // false when the client had already deregistered itself
      }
      lock.lock();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::vector<Client> clients_;  // registered clients, until their process is gone
  std::thread reaper_;
};

}  // namespace

struct StreamingHost::Impl {
  bool in_process = false;
  std::string description;
  uint64_t max_payload = 0;
  std::unique_ptr<iox::roudi::IceOryxRouDiComponents> components;
  std::unique_ptr<iox::roudi::RouDi> roudi;
  std::unique_ptr<iox::runtime::PoshRuntimeSingleProcess> runtime;

  ~Impl() {
    runtime.reset();
    roudi.reset();
    components.reset();
  }
};

StreamingHost::StreamingHost(const std::vector<CameraConfig>& cameras, const StreamingOptions& options) {
  if (detail::g_host_alive.exchange(true)) {
    throw std::logic_error("StreamingHost: only one may exist per process");
  }
  try {
    for (const CameraConfig& c : cameras) validate(c);
    if (options.chunks_per_camera < 4 || options.chunks_per_camera > 1024) {
      throw std::invalid_argument("StreamingOptions.chunks_per_camera must lie in 4..1024");
    }
    if (detail::g_client_runtime.load()) {
      throw std::logic_error("StreamingHost: this process already registered with RouDi as a client");
    }
    detail::set_iceoryx_log_level(options.verbose);
    impl_ = std::make_unique<Impl>();
    const std::string name =
        options.runtime_name.empty() ? "doppel-" + std::to_string(::getpid()) : options.runtime_name;
    const bool running = detail::roudi_lock_held();
    if (running && options.roudi == RouDiMode::kInProcess) {
      throw std::runtime_error("a RouDi already runs on this machine (an iox-roudi or another doppel); "
                               "use the external RouDi or stop it first");
    }
    if (!running && options.roudi == RouDiMode::kExternal) {
      throw std::runtime_error("no RouDi runs on this machine: start iox-roudi first or let doppel start its own");
    }
    uint64_t largest_frame = 0;
    for (const CameraConfig& c : cameras) {
      largest_frame = std::max<uint64_t>(largest_frame, pool_payload_for(frame_payload_bytes(c)));
    }

    if (!running) {
      // Pools: small ones for info topics and other users, then one pool per distinct frame size.
      std::map<uint32_t, uint32_t> pools = {{128, 1024}, {1024, 512}, {16384, 128}, {131072, 16}};
      for (const CameraConfig& c : cameras) {
        pools[static_cast<uint32_t>(pool_payload_for(frame_payload_bytes(c)))] += options.chunks_per_camera;
      }
      iox::mepoo::MePooConfig mepoo;
      uint64_t data_bytes = 0;
      std::string sizes;
      for (const auto& [size, count] : pools) {
        mepoo.addMemPool({size, count});
        data_bytes += (uint64_t{size} + 128) * count;
        impl_->max_payload = std::max<uint64_t>(impl_->max_payload, size);
        if (size >= 131072) sizes += " " + std::to_string(count) + "x" + std::to_string(size / 1024) + "KiB";
      }
      struct statvfs shm {};
      if (::statvfs("/dev/shm", &shm) == 0) {
        const uint64_t free_bytes = static_cast<uint64_t>(shm.f_bavail) * shm.f_frsize;
        if (free_bytes < data_bytes + kMgmtSegmentEstimateBytes) {
          throw std::runtime_error("/dev/shm has " + std::to_string(free_bytes >> 20) + " MiB free, RouDi needs about " +
                                   std::to_string((data_bytes + kMgmtSegmentEstimateBytes) >> 20) +
                                   " MiB (mount a larger tmpfs or use fewer/smaller cameras)");
        }
      }
      iox::RouDiConfig_t config;
      const auto group = iox::posix::PosixGroup::getGroupOfCurrentProcess().getName();
      config.m_sharedMemorySegments.push_back({group, group, mepoo});
      {
        // iceoryx reports each shared-memory reservation on std::clog; only --verbose shows it.
        std::ostringstream discarded;
        std::streambuf* const clog_buffer = options.verbose ? nullptr : std::clog.rdbuf(discarded.rdbuf());
        const iox::cxx::GenericRAII restore_clog([] {}, [clog_buffer] {
          if (clog_buffer != nullptr) std::clog.rdbuf(clog_buffer);
        });
        impl_->components = std::make_unique<iox::roudi::IceOryxRouDiComponents>(config);
      }
      {
        const QuietStdout quiet(!options.verbose);
        impl_->roudi = std::make_unique<ClientReapingRouDi>(impl_->components->rouDiMemoryManager,
                                                            impl_->components->portManager);
        // Registering waits for RouDi's message thread, which prints its line before it serves.
        impl_->runtime = std::make_unique<iox::runtime::PoshRuntimeSingleProcess>(
            iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
      }
      impl_->in_process = true;
      impl_->description = "camera: started RouDi inside this process (" + std::to_string(data_bytes >> 20) +
                           " MiB of frame pools:" + sizes + ")";
    } else {
      iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
      detail::g_client_runtime = true;
      impl_->max_payload = external_max_payload(options.introspection_timeout_s);
      if (impl_->max_payload == 0) {
        throw std::runtime_error("a RouDi runs on this machine but did not report its memory pools within " +
                                 std::to_string(options.introspection_timeout_s) + " s");
      }
      impl_->description = "camera: RouDi already running on this machine (iox-roudi or another doppel): using it "
                           "(largest chunk payload " + std::to_string(impl_->max_payload) + " bytes)";
      if (largest_frame > impl_->max_payload) {
        throw std::runtime_error("the running RouDi's largest chunk holds " + std::to_string(impl_->max_payload) +
                                 " bytes but a frame needs " + std::to_string(largest_frame) +
                                 ": add a mempool to its config or stop it and let doppel start its own");
      }
    }
  } catch (...) {
    impl_.reset();
    detail::g_host_alive = false;
    throw;
  }
}

StreamingHost::~StreamingHost() {
  impl_.reset();
  detail::g_host_alive = false;
}

bool StreamingHost::roudi_in_process() const noexcept { return impl_->in_process; }
const std::string& StreamingHost::description() const noexcept { return impl_->description; }
uint64_t StreamingHost::max_payload_bytes() const noexcept { return impl_->max_payload; }
bool StreamingHost::exists() noexcept { return detail::g_host_alive.load(); }

struct CameraStream::Impl {
  CameraConfig config;
  uint32_t payload_bytes;
  Renderer renderer;
  iox::popo::UntypedPublisher frames;
  iox::popo::UntypedPublisher info;
  iox::popo::UntypedSubscriber settings;
  CameraInfo info_record;  // what the info topic says; camera thread after construction
  uint64_t sequence = 0;
  std::atomic<uint64_t> published{0};
  std::atomic<uint64_t> dropped{0};
  std::atomic<uint64_t> skipped{0};
  std::atomic<uint64_t> settings_applied{0};
  std::atomic<uint64_t> settings_rejected{0};
  std::atomic<double> last_render_ms{0.0};
  std::mutex noise_mutex;
  NoiseConfig pending_noise;
  std::atomic<bool> noise_pending{false};

  static iox::popo::PublisherOptions frame_options() {
    iox::popo::PublisherOptions o;
    o.historyCapacity = 1;
    o.subscriberTooSlowPolicy = iox::popo::ConsumerTooSlowPolicy::DISCARD_OLDEST_DATA;
    return o;
  }
  static iox::popo::PublisherOptions info_options() {
    iox::popo::PublisherOptions o;
    o.historyCapacity = 1;
    return o;
  }
  static iox::popo::SubscriberOptions settings_options() {
    iox::popo::SubscriberOptions o;
    o.queueCapacity = 8;
    o.historyRequest = 1;
    o.queueFullPolicy = iox::popo::QueueFullPolicy::DISCARD_OLDEST_DATA;
    return o;
  }

  explicit Impl(const CameraConfig& c)
      : config(c),
        payload_bytes(static_cast<uint32_t>(frame_payload_bytes(c))),
        renderer(c.lens, c.width_px, c.height_px, c.format, c.render_threads),
        frames(detail::service(c.name, detail::kFramesEvent), frame_options()),
        info(detail::service(c.name, detail::kInfoEvent), info_options()),
        settings(detail::service(c.name, detail::kSettingsEvent), settings_options()) {
    renderer.set_noise(c.noise);
  }

  // Publishes info_record (history 1: what late subscribers and `doppel-camera list` see). Does not
  // allocate; a record that finds no free chunk is skipped (the next change publishes again).
  void publish_info() noexcept {
    info.loan(sizeof(CameraInfo), alignof(CameraInfo)).and_then([this](void* chunk) {
      concurrency::taken_over(chunk);
      new (chunk) CameraInfo(info_record);
      concurrency::handing_over(chunk);
      info.publish(chunk);
    });
  }
};

CameraStream::CameraStream(StreamingHost& host, const CameraConfig& config) {
  validate(config);
  const uint64_t payload = pool_payload_for(frame_payload_bytes(config));
  if (payload > host.max_payload_bytes()) {
    throw std::runtime_error("camera '" + config.name + "': a frame needs " + std::to_string(payload) +
                             " bytes but the largest chunk holds " + std::to_string(host.max_payload_bytes()) +
                             " (give the camera to StreamingHost so the pools are sized for it)");
  }
  if (detail::service_offered(config.name, detail::kFramesEvent)) {
    throw std::runtime_error("camera '" + config.name + "' is already published on this machine (another doppel?)");
  }
  impl_ = std::make_unique<Impl>(config);
  // Discovery record, kept by the publisher's history for late subscribers.
  CameraInfo& info = impl_->info_record;
  std::strncpy(info.name, config.name.c_str(), sizeof(info.name) - 1);
  if (config.mount.kind == CameraMount::Kind::kBody) {
    std::strncpy(info.body, config.mount.body.c_str(), sizeof(info.body) - 1);
  }
  info.format = static_cast<uint32_t>(config.format);
  info.width_px = config.width_px;
  info.height_px = config.height_px;
  info.fps = config.fps;
  info.lens = config.lens;
  info.payload_bytes = impl_->payload_bytes;
  info.pid = static_cast<int32_t>(::getpid());
  info.noise = config.noise;
  info.robot_file_order = config.robot_file_order;
  impl_->publish_info();
}

CameraStream::~CameraStream() = default;

FrameHeader* CameraStream::loan_frame(const Eigen::Isometry3d& X_WC, double sim_time_s) noexcept {
  Impl& s = *impl_;
  const uint64_t sequence = s.sequence++;
  auto loaned = s.frames.loan(s.payload_bytes, kFrameAlignment);
  if (loaned.has_error()) {
    s.dropped.fetch_add(1, std::memory_order_relaxed);
    return nullptr;
  }
  void* chunk = loaned.value();
  concurrency::taken_over(chunk);  // a recycled chunk: the last subscriber's reads came before
  // Only the header is constructed: the pixels are written by the renderer, never zeroed first.
  auto* h = new (chunk) FrameHeader();
  const CameraConfig& c = s.config;
  h->header_bytes = sizeof(FrameHeader);
  h->sequence = sequence;
  h->sim_time_ns = static_cast<int64_t>(std::llround(sim_time_s * 1e9));
  const double stamp_offset_s = c.stamp == ExposureStamp::kStart ? -0.5 * c.exposure_s
                                : c.stamp == ExposureStamp::kEnd ? 0.5 * c.exposure_s
                                                                 : 0.0;
  h->exposure_time_ns = h->sim_time_ns + static_cast<int64_t>(std::llround(stamp_offset_s * 1e9));
  h->wall_time_ns = clock_now_ns(CLOCK_REALTIME);
  h->render_start_mono_ns = monotonic_now_ns();
  h->format = static_cast<uint32_t>(c.format);
  h->width_px = c.width_px;
  h->height_px = c.height_px;
  h->stride_bytes = static_cast<uint32_t>(row_bytes(c.format, c.width_px));
  h->pixel_offset = align64(sizeof(FrameHeader));
  h->pixel_bytes = h->stride_bytes * static_cast<uint32_t>(c.height_px);
  if (c.annotations) {
    h->annotation_offset = align64(uint64_t{h->pixel_offset} + h->pixel_bytes);
    h->annotation_bytes = sizeof(FrameAnnotations);
    new (static_cast<uint8_t*>(chunk) + h->annotation_offset) FrameAnnotations;
  }
  const Eigen::Quaterniond q(X_WC.linear());
  h->position_w_m[0] = X_WC.translation().x();
  h->position_w_m[1] = X_WC.translation().y();
  h->position_w_m[2] = X_WC.translation().z();
  h->orientation_w[0] = q.w();
  h->orientation_w[1] = q.x();
  h->orientation_w[2] = q.y();
  h->orientation_w[3] = q.z();
  h->lens = c.lens;
  h->fps = c.fps;
  h->frames_dropped = s.dropped.load(std::memory_order_relaxed);
  std::strncpy(h->camera_name, c.name.c_str(), sizeof(h->camera_name) - 1);
  return h;
}

void CameraStream::publish_frame(FrameHeader* frame) noexcept {
  Impl& s = *impl_;
  frame->publish_mono_ns = monotonic_now_ns();
  s.last_render_ms.store(1e-6 * static_cast<double>(frame->publish_mono_ns - frame->render_start_mono_ns),
                         std::memory_order_relaxed);
  concurrency::handing_over(frame);
  s.frames.publish(frame);
  s.published.fetch_add(1, std::memory_order_relaxed);
}

bool CameraStream::render_and_publish(const physics::SceneView& scene, const Eigen::Isometry3d& X_WC,
                                      double sim_time_s) {
  Impl& s = *impl_;
  poll_settings();
  if (!s.frames.hasSubscribers()) {
    ++s.sequence;
    s.skipped.fetch_add(1, std::memory_order_relaxed);
    return false;
  }
  FrameHeader* h = loan_frame(X_WC, sim_time_s);
  if (h == nullptr) return false;
  auto* annotations = const_cast<FrameAnnotations*>(frame_annotations(h));
  s.renderer.render(scene, X_WC, h->sequence, reinterpret_cast<uint8_t*>(h) + h->pixel_offset, annotations);
  publish_frame(h);
  return true;
}

void CameraStream::set_noise(const NoiseConfig& noise) {
  validate(noise);
  std::lock_guard<std::mutex> lock(impl_->noise_mutex);
  impl_->pending_noise = noise;
  impl_->noise_pending.store(true, std::memory_order_release);
}

bool CameraStream::poll_settings() noexcept {
  Impl& s = *impl_;
  bool changed = false;
  NoiseConfig next;
  uint64_t request_id = 0;
  if (s.noise_pending.load(std::memory_order_acquire)) {
    std::unique_lock<std::mutex> lock(s.noise_mutex, std::try_to_lock);
    if (lock.owns_lock()) {
      next = s.pending_noise;  // validated by set_noise()
      changed = true;
      s.noise_pending.store(false, std::memory_order_release);
    }
  }
  bool rejected = false;
  for (auto taken = s.settings.take(); !taken.has_error(); taken = s.settings.take()) {
    const void* payload = taken.value();
    concurrency::taken_over(payload);
    const auto* chunk = iox::mepoo::ChunkHeader::fromUserPayload(payload);
    NoiseRequest request;
    const bool complete = chunk->userPayloadSize() >= sizeof(NoiseRequest);
    if (complete) std::memcpy(&request, payload, sizeof(NoiseRequest));
    concurrency::handing_over(payload);
    s.settings.release(payload);
    if (!complete || invalid_noise_field(request.noise).size() > 0) {
      s.settings_rejected.fetch_add(1, std::memory_order_relaxed);
      rejected = true;
      continue;
    }
    next = request.noise;  // the last valid request wins
    request_id = request.request_id;
    changed = true;
  }
  if (!changed && !rejected) return false;
  if (changed) {
    s.renderer.set_noise(next);  // valid: cannot throw
    s.info_record.noise = next;
    s.info_record.noise_request_id = request_id;
    s.info_record.noise_from_sequence = s.sequence;
    s.settings_applied.fetch_add(1, std::memory_order_relaxed);
  }
  s.info_record.settings_rejected = s.settings_rejected.load(std::memory_order_relaxed);
  s.publish_info();
  return changed;
}

const NoiseConfig& CameraStream::noise() const noexcept { return impl_->info_record.noise; }

bool CameraStream::has_subscribers() const noexcept { return impl_->frames.hasSubscribers(); }

StreamStats CameraStream::stats() const noexcept {
  StreamStats s;
  s.published = impl_->published.load(std::memory_order_relaxed);
  s.dropped = impl_->dropped.load(std::memory_order_relaxed);
  s.skipped_idle = impl_->skipped.load(std::memory_order_relaxed);
  s.settings_applied = impl_->settings_applied.load(std::memory_order_relaxed);
  s.settings_rejected = impl_->settings_rejected.load(std::memory_order_relaxed);
  s.last_render_ms = impl_->last_render_ms.load(std::memory_order_relaxed);
  return s;
}

const CameraConfig& CameraStream::config() const noexcept { return impl_->config; }

bool camera_offered(const std::string& name) { return detail::service_offered(name, detail::kFramesEvent); }

}  // namespace doppel::camera
