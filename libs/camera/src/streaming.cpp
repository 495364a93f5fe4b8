#include "camera/streaming.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <mutex>
#include <new>
#include <stdexcept>

#include "base/monotonic_clock.h"
#include "camera/frame.h"
#include "camera/renderer.h"
#include "concurrency/sanitizer_handover.h"
#include "iceoryx_posh/mepoo/chunk_header.hpp"
#include "iceoryx_posh/mepoo/chunk_settings.hpp"
#include "iceoryx_posh/popo/untyped_publisher.hpp"
#include "iceoryx_posh/popo/untyped_subscriber.hpp"
#include "iox_support.h"
#include "roudi/host.h"

namespace doppel::camera {
namespace {

uint32_t align64(uint64_t n) { return static_cast<uint32_t>((n + 63) / 64 * 64); }

// Pool payload size a frame of `payload` bytes needs: iceoryx places the 64-byte aligned payload
// after its chunk header, so a pool of exactly `payload` bytes would not fit it (and loaning a chunk
// larger than every pool aborts the process).
uint64_t pool_payload_for(uint64_t payload) {
  auto settings = iox::mepoo::ChunkSettings::create(static_cast<uint32_t>(payload), kFrameAlignment);
  if (settings.has_error()) throw std::invalid_argument("frame payload of " + std::to_string(payload) + " bytes");
  return align64(settings.value().requiredChunkSize() - sizeof(iox::mepoo::ChunkHeader));
}

// Set while a StreamingHost exists: the cameras of a process share one host.
std::atomic<bool> g_streaming_host{false};

}  // namespace

struct StreamingHost::Impl {
  std::shared_ptr<roudi::Host> host;
  std::string description;
};

StreamingHost::StreamingHost(const std::vector<CameraConfig>& cameras, const StreamingOptions& options) {
  if (g_streaming_host.exchange(true)) {
    throw std::logic_error("StreamingHost: only one may exist per process");
  }
  try {
    for (const CameraConfig& c : cameras) validate(c);
    if (options.chunks_per_camera < 4 || options.chunks_per_camera > 1024) {
      throw std::invalid_argument("StreamingOptions.chunks_per_camera must lie in 4..1024");
    }
    if (roudi::client_registered()) {
      throw std::logic_error("StreamingHost: this process already registered with RouDi as a client");
    }
    roudi::HostOptions host_options;
    host_options.mode = options.roudi;
    host_options.runtime_name = options.runtime_name;
    host_options.introspection_timeout_s = options.introspection_timeout_s;
    host_options.verbose = options.verbose;
    uint64_t largest_frame = 0;
    for (const CameraConfig& c : cameras) {
      const uint64_t payload = pool_payload_for(frame_payload_bytes(c));
      largest_frame = std::max(largest_frame, payload);
      host_options.pools.push_back({static_cast<uint32_t>(payload), options.chunks_per_camera});
    }
    impl_ = std::make_unique<Impl>();
    impl_->host = roudi::Host::share(host_options);
    const roudi::Host& host = *impl_->host;
    if (host.in_process()) {
      std::string sizes;
      for (const auto& [size, count] : host.pools()) {
        if (size >= 131072) sizes += " " + std::to_string(count) + "x" + std::to_string(size / 1024) + "KiB";
      }
      impl_->description = "camera: started RouDi inside this process (" + std::to_string(host.pool_bytes() >> 20) +
                           " MiB of frame pools:" + sizes + ")";
    } else {
      impl_->description = "camera: RouDi already running on this machine (iox-roudi or another doppel): using it "
                           "(largest chunk payload " + std::to_string(host.max_payload_bytes()) + " bytes)";
      if (largest_frame > host.max_payload_bytes()) {
        throw std::runtime_error("the running RouDi's largest chunk holds " + std::to_string(host.max_payload_bytes()) +
                                 " bytes but a frame needs " + std::to_string(largest_frame) +
                                 ": add a mempool to its config or stop it and let doppel start its own");
      }
    }
  } catch (...) {
    impl_.reset();
    g_streaming_host = false;
    throw;
  }
}

StreamingHost::~StreamingHost() {
  impl_.reset();
  g_streaming_host = false;
}

bool StreamingHost::roudi_in_process() const noexcept { return impl_->host->in_process(); }
const std::string& StreamingHost::description() const noexcept { return impl_->description; }
uint64_t StreamingHost::max_payload_bytes() const noexcept { return impl_->host->max_payload_bytes(); }

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
