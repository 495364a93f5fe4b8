// libdoppel_v4l2.so: the V4L2 capture device behind /dev/video<n> under doppel-run (docs/camera.md,
// "V4L2"). Loaded by the preload library on the first open of a camera device; answers the ioctls
// a capture driver built on videobuf2 and the control framework answers (linux/videodev2.h, the V4L2
// spec "Video Capture Interface", "Streaming I/O (Memory Mapping)", "User Controls"), fed by the
// camera's iceoryx stream.
//
// One worker thread per streaming camera takes each frame from shared memory and copies it once,
// converted (v4l2_format.h), into the oldest queued buffer, as a DMA engine fills the next buffer;
// with none queued the frame is lost and the sequence number shows the gap. The descriptor the
// program gets is an eventfd, readable while a filled buffer waits, so poll/select/epoll work
// unchanged; a waiting control event, V4L2's POLLPRI, has an eventfd of its own per descriptor, which
// the shim's poll and select report as the camera's POLLPRI. The eventfds are read and written with
// raw system calls: the shim interposes read().
//
// Under lockstep (set_lockstep) there is no worker: doppel publishes each frame before any
// controller thread sees its simulation time, and the program's own thread moves the frames into
// its buffers when it polls, dequeues or reads (pump), so what it gets depends on simulation time
// only (docs/lockstep.md, "Cameras").
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <linux/videodev2.h>
#include <stdio.h>
#include <string.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "camera/client.h"
#include "shim/v4l2_format.h"
#include "v4l2_api.h"

namespace doppel::shim {
namespace {

constexpr uint32_t kMaxBuffers = 32;
constexpr uint32_t kMinBuffers = 2;
constexpr uint32_t kCaps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_READWRITE | V4L2_CAP_EXT_PIX_FORMAT;
constexpr uint32_t kTimestampFlags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
constexpr uint32_t kLockstepQueue = 16;  // most frames waiting in shared memory for one lockstep reader
constexpr double kConnectTimeoutS = 5.0;  // lockstep: STREAMON waits this long for doppel's publisher

// Lockstep: simulation time (the shim's), and what CLOCK_MONOTONIC reads at simulation time 0.
int64_t (*g_sim_now)() = nullptr;
int64_t g_monotonic_offset_ns = 0;
bool lockstep() { return g_sim_now != nullptr; }

void say(const std::string& text) {
  const std::string line = "doppel-run shim: " + text + "\n";
  [[maybe_unused]] const long n = syscall(SYS_write, 2, line.data(), line.size());
}

int fail(int error) {
  errno = error;
  return -1;
}

void eventfd_set(int fd) {
  const uint64_t one = 1;
  [[maybe_unused]] const long n = syscall(SYS_write, fd, &one, sizeof(one));
}
// Only called while the counter is non-zero (the device's lock guards the invariant), so the read
// never blocks.
void eventfd_clear(int fd) {
  uint64_t value = 0;
  [[maybe_unused]] const long n = syscall(SYS_read, fd, &value, sizeof(value));
}

enum class BufferState { kDequeued, kQueued, kFilling, kDone };

struct Buffer {
  BufferState state = BufferState::kDequeued;
  uint32_t bytesused = 0;
  uint32_t sequence = 0;
  timeval timestamp{};
  uint32_t flags = 0;          // V4L2_BUF_FLAG_ERROR on a short frame
  unsigned long userptr = 0;   // USERPTR: the program's memory
  uint32_t user_length = 0;
  int mappings = 0;            // program mmaps of this buffer alive
};

struct File;

// One camera: formats, controls and the buffer queue, shared by every descriptor open on it.
struct Camera {
  std::string name;
  SourceCamera source;
  camera::NoiseConfig configured_noise;  // as doppel started it: what automatic white balance keeps

  std::mutex mutex;
  std::condition_variable changed;
  Mode mode;
  ControlValues controls;
  ToneCurves curves;

  File* owner = nullptr;      // the descriptor that allocated buffers (or reads)
  uint32_t memory = 0;        // V4L2_MEMORY_MMAP / USERPTR
  std::vector<Buffer> buffers;
  uint32_t buffer_stride = 0;  // page-aligned bytes per MMAP buffer in the memfd
  int memfd = -1;
  uint8_t* memory_base = nullptr;
  std::deque<uint32_t> queued;
  std::deque<uint32_t> done;
  bool streaming = false;
  bool reading = false;       // read() I/O: the worker keeps the newest frame in `pending`
  std::optional<camera::Frame> pending;
  bool have_base = false;
  uint64_t base_sequence = 0;  // frame sequence number of V4L2 sequence 0
  int64_t started_sim_ns = 0;  // lockstep: simulation time of STREAMON (or the first read)
  std::thread worker;
  std::atomic<bool> stop{false};
  std::unique_ptr<camera::FrameSubscriber> subscriber;

  std::thread settings_thread;  // sends white-balance changes to the camera model
  bool settings_pending = false;
  bool settings_quit = false;
};

// A descriptor's subscription to a control's events (VIDIOC_SUBSCRIBE_EVENT, V4L2_EVENT_CTRL). As in
// the control framework, it holds one event at most: a newer change replaces a waiting event and
// keeps its change bits.
struct Subscription {
  uint32_t id = 0;     // the control
  uint32_t flags = 0;  // V4L2_EVENT_SUB_FL_*
  bool waiting = false;
  v4l2_event event{};
};

struct File {
  int fd = -1;
  Camera* camera = nullptr;
  uint32_t priority = V4L2_PRIORITY_DEFAULT;
  // Control events, guarded by the camera's lock. V4L2 reports a waiting event as POLLPRI, which
  // the descriptor (an eventfd) cannot raise: `event_fd`, made at the first subscription, is
  // readable while one waits, and the shim's poll and select report that as the camera's POLLPRI.
  int event_fd = -1;
  std::vector<Subscription> subscriptions;
  std::deque<uint32_t> waiting;  // controls of the waiting events, oldest first (DQEVENT's order)
  uint32_t sequence = 0;         // of the next event queued
};

struct Mapping {
  uintptr_t address;
  size_t length;
  Camera* camera;
  uint32_t index;
};

std::mutex g_mutex;  // the tables below
std::map<int, File*> g_files;
std::map<std::string, Camera*> g_cameras;
std::vector<Mapping> g_mappings;
bool g_connected = false;

File* file_of(int fd) {
  std::lock_guard lock(g_mutex);
  const auto it = g_files.find(fd);
  return it == g_files.end() ? nullptr : it->second;
}

uint32_t max_priority(const Camera& cam) {
  uint32_t p = V4L2_PRIORITY_BACKGROUND;
  std::lock_guard lock(g_mutex);
  for (const auto& [fd, file] : g_files) {
    if (file->camera == &cam) p = std::max(p, file->priority);
  }
  return p;
}

// Another descriptor of the camera holds a higher priority (V4L2 "Application Priority").
bool outranked(const File& file) { return file.priority < max_priority(*file.camera); }

// The camera name for "#<n>": the n-th camera of robot 0 (a camera on a body, not "robot<r>-..."),
// in the robot file's order.
std::string resolve_camera(const std::string& wanted, const std::vector<camera::CameraInfo>& cameras) {
  if (wanted.empty() || wanted[0] != '#') return wanted;
  std::vector<std::pair<int32_t, std::string>> robot_cameras;
  for (const auto& info : cameras) {
    const std::string name = info.name;
    const bool other_robot = name.rfind("robot", 0) == 0 && name.size() > 5 && name[5] >= '0' && name[5] <= '9';
    if (info.body[0] != '\0' && !other_robot) robot_cameras.emplace_back(info.robot_file_order, name);
  }
  std::sort(robot_cameras.begin(), robot_cameras.end());
  const std::size_t n = static_cast<std::size_t>(std::atoi(wanted.c_str() + 1));
  return n < robot_cameras.size() ? robot_cameras[n].second : std::string();
}

void stop_worker(Camera& cam, std::unique_lock<std::mutex>& lock);

// At exit, before iceoryx's runtime goes: workers and settings threads stop, frames go back.
void stop_all() {
  std::vector<Camera*> cameras;
  {
    std::lock_guard lock(g_mutex);
    for (const auto& [name, cam] : g_cameras) cameras.push_back(cam);
  }
  for (Camera* cam : cameras) {
    std::unique_lock lock(cam->mutex);
    cam->streaming = false;
    stop_worker(*cam, lock);
    cam->pending.reset();
    cam->settings_quit = true;
    cam->changed.notify_all();
    lock.unlock();
    if (cam->settings_thread.joinable()) cam->settings_thread.join();
  }
}

Camera* camera_for(const char* device, const std::string& wanted) {
  {
    std::lock_guard lock(g_mutex);
    if (const auto it = g_cameras.find(wanted); it != g_cameras.end()) return it->second;
  }
  if (!g_connected) {
    camera::connect_client("doppel-v4l2");
    g_connected = true;
    std::atexit(stop_all);  // registered after iceoryx's runtime, so it runs before its teardown
  }
  const std::vector<camera::CameraInfo> cameras = camera::list_cameras(1.0);
  const std::string name = resolve_camera(wanted, cameras);
  for (const auto& info : cameras) {
    if (name != info.name) continue;
    auto cam = std::make_unique<Camera>();
    cam->name = name;
    cam->source = {info.format, info.width_px, info.height_px, info.fps};
    cam->configured_noise = info.noise;
    if (fourcc_of(info.format) == 0) {
      say(std::string(device) + ": camera " + name + " has an unknown pixel format");
      return nullptr;
    }
    cam->mode = mode_at(cam->source, format_at(cam->source, 0), 0);
    cam->controls = default_controls(info.fps);
    cam->curves = tone_curves(cam->controls, info.fps, info.format);
    std::lock_guard lock(g_mutex);
    Camera* raw = cam.release();
    g_cameras[wanted] = raw;
    return raw;
  }
  say(std::string(device) + ": doppel publishes no camera " + wanted + " (" + std::to_string(cameras.size()) +
      " camera(s) published; doppel-camera list)");
  errno = ENOENT;  // as for a device node that does not exist
  return nullptr;
}

// ---- streaming ------------------------------------------------------------------------------

// Real time: when the frame was complete. Lockstep: its simulation time on the program's
// CLOCK_MONOTONIC (the frame is ready at the time of its scene: no readout latency is modelled).
void fill_timestamp(Buffer& b, const camera::FrameHeader& h) {
  const int64_t ns = lockstep() ? g_monotonic_offset_ns + h.sim_time_ns : h.publish_mono_ns;
  b.timestamp.tv_sec = static_cast<time_t>(ns / 1000000000);
  b.timestamp.tv_usec = static_cast<suseconds_t>((ns % 1000000000) / 1000);
}

uint8_t* buffer_memory(Camera& cam, uint32_t index) {
  if (cam.memory == V4L2_MEMORY_USERPTR) return reinterpret_cast<uint8_t*>(cam.buffers[index].userptr);
  return cam.memory_base + static_cast<size_t>(index) * cam.buffer_stride;
}

bool frame_matches(const Camera& cam, const camera::FrameHeader& h) {
  return h.width_px == cam.source.width && h.height_px == cam.source.height && h.format == cam.source.format;
}

// One frame from shared memory into the oldest queued buffer (with read(): kept as the newest).
// Caller holds the camera's lock; it is released during the copy.
void deliver(Camera& cam, camera::Frame&& frame, std::unique_lock<std::mutex>& lock) {
  const camera::FrameHeader& h = frame.header();
  // Lockstep: a frame of a scene not after STREAMON is not this stream's (its history).
  if (lockstep() && h.sim_time_ns <= cam.started_sim_ns) return;
  if (!cam.have_base) {
    cam.have_base = true;
    cam.base_sequence = h.sequence;
  }
  if (cam.reading) {
    const bool was_empty = !cam.pending.has_value();
    cam.pending = std::move(frame);
    if (was_empty && cam.owner != nullptr) eventfd_set(cam.owner->fd);
    cam.changed.notify_all();
    return;
  }
  if (cam.queued.empty()) return;  // no buffer: the frame is lost, the next sequence shows it
  const uint32_t index = cam.queued.front();
  cam.queued.pop_front();
  Buffer& b = cam.buffers[index];
  b.state = BufferState::kFilling;
  const Mode mode = cam.mode;
  const ToneCurves curves = cam.curves;
  uint8_t* out = buffer_memory(cam, index);
  lock.unlock();
  bool ok = frame_matches(cam, h);
  if (ok) convert_frame(cam.source, frame.pixels(), h.stride_bytes, mode, curves, out);
  lock.lock();
  b.bytesused = ok ? mode.sizeimage : 0;
  b.flags = ok ? 0 : V4L2_BUF_FLAG_ERROR;
  b.sequence = static_cast<uint32_t>(h.sequence - cam.base_sequence);
  fill_timestamp(b, h);
  if (!cam.streaming) {  // STREAMOFF while copying: the buffer goes back to the program
    b.state = BufferState::kDequeued;
    return;
  }
  b.state = BufferState::kDone;
  const bool was_empty = cam.done.empty();
  cam.done.push_back(index);
  if (was_empty && cam.owner != nullptr) eventfd_set(cam.owner->fd);
  cam.changed.notify_all();
}

void worker_loop(Camera* cam) {
  while (!cam->stop.load()) {
    std::optional<camera::Frame> frame = cam->subscriber->wait_take(0.05);
    if (!frame) continue;
    std::unique_lock lock(cam->mutex);
    deliver(*cam, std::move(*frame), lock);
  }
}

// Lockstep: every frame doppel published so far (it publishes a frame before any controller
// thread sees its time). Caller holds the camera's lock.
void pump_camera(Camera& cam, std::unique_lock<std::mutex>& lock) {
  if (!lockstep()) return;
  while (cam.subscriber != nullptr) {
    std::optional<camera::Frame> frame = cam.subscriber->try_take();
    if (!frame) return;
    deliver(cam, std::move(*frame), lock);
  }
}

// Caller holds the camera's lock.
int start_worker(Camera& cam) {
  camera::SubscriberOptions options;
  if (lockstep()) {
    // Frames wait in shared memory until the program's thread takes them: room for as many as it
    // has buffers (with read(), the newest two).
    options.queue_capacity = cam.reading ? 2 : std::clamp(static_cast<uint32_t>(cam.buffers.size()), kMinBuffers, kLockstepQueue);
  }
  try {
    cam.subscriber = std::make_unique<camera::FrameSubscriber>(cam.name, options);
  } catch (const std::exception& e) {
    say(cam.name + ": " + e.what());
    return fail(EIO);
  }
  cam.have_base = false;
  if (lockstep()) {
    // The program's thread runs for doppel meanwhile (the shim bypasses), so no simulation time
    // passes: every frame due after this instant reaches the subscription.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(kConnectTimeoutS);
    while (!cam.subscriber->connected()) {
      if (std::chrono::steady_clock::now() > deadline) {
        say(cam.name + ": doppel's camera did not accept the subscription within 5 s (is doppel running?)");
        cam.subscriber.reset();
        return fail(EIO);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    cam.started_sim_ns = g_sim_now();
    return 0;
  }
  cam.stop = false;
  cam.worker = std::thread(worker_loop, &cam);
  return 0;
}

// Caller holds the camera's lock; stops the worker and drops its subscription.
void stop_worker(Camera& cam, std::unique_lock<std::mutex>& lock) {
  if (cam.worker.joinable()) {
    cam.stop = true;
    lock.unlock();
    cam.worker.join();
    lock.lock();
  }
  cam.subscriber.reset();
}

void stream_off(Camera& cam, std::unique_lock<std::mutex>& lock) {
  cam.streaming = false;
  stop_worker(cam, lock);
  if (!cam.done.empty() && cam.owner != nullptr) eventfd_clear(cam.owner->fd);
  cam.queued.clear();
  cam.done.clear();
  for (Buffer& b : cam.buffers) {
    b.state = BufferState::kDequeued;
  }
  cam.changed.notify_all();
}

void stop_reading(Camera& cam, std::unique_lock<std::mutex>& lock) {
  if (!cam.reading) return;
  stop_worker(cam, lock);
  if (cam.pending && cam.owner != nullptr) eventfd_clear(cam.owner->fd);
  cam.pending.reset();
  cam.reading = false;
}

void free_buffers(Camera& cam) {
  if (!cam.done.empty() && cam.owner != nullptr) eventfd_clear(cam.owner->fd);
  cam.queued.clear();
  cam.done.clear();
  if (cam.memory_base != nullptr) ::munmap(cam.memory_base, static_cast<size_t>(cam.buffer_stride) * cam.buffers.size());
  if (cam.memfd >= 0) syscall(SYS_close, cam.memfd);  // program mappings keep their pages (orphaned buffers)
  cam.memory_base = nullptr;
  cam.memfd = -1;
  cam.buffers.clear();
  std::lock_guard lock(g_mutex);
  for (Mapping& m : g_mappings) {
    if (m.camera == &cam) m.camera = nullptr;
  }
}

// ---- camera model (white balance) -----------------------------------------------------------

void settings_loop(Camera* cam) {
  std::unique_lock lock(cam->mutex);
  for (;;) {
    cam->changed.wait(lock, [cam] { return cam->settings_pending || cam->settings_quit; });
    if (cam->settings_quit) return;
    cam->settings_pending = false;
    camera::NoiseConfig noise = cam->configured_noise;
    if (cam->controls.white_balance_auto == 0) {
      double gains[3];
      white_balance_gains(cam->controls.white_balance_temperature, gains);
      noise.wb_red_gain = gains[0];
      noise.wb_green_gain = gains[1];
      noise.wb_blue_gain = gains[2];
    }
    lock.unlock();
    try {
      camera::set_camera_noise(cam->name, noise, 2.0);
    } catch (const std::exception& e) {
      say(cam->name + ": white balance not applied: " + e.what());
    }
    lock.lock();
  }
}

void white_balance_changed(Camera& cam) {
  cam.settings_pending = true;
  if (!cam.settings_thread.joinable()) cam.settings_thread = std::thread(settings_loop, &cam);
  cam.changed.notify_all();
}

// ---- controls --------------------------------------------------------------------------------

int32_t* control_value(ControlValues& v, uint32_t id) {
  switch (id) {
    case V4L2_CID_BRIGHTNESS: return &v.brightness;
    case V4L2_CID_CONTRAST: return &v.contrast;
    case V4L2_CID_SATURATION: return &v.saturation;
    case V4L2_CID_GAIN: return &v.gain;
    case V4L2_CID_AUTO_WHITE_BALANCE: return &v.white_balance_auto;
    case V4L2_CID_WHITE_BALANCE_TEMPERATURE: return &v.white_balance_temperature;
    case V4L2_CID_EXPOSURE_AUTO: return &v.exposure_auto;
    case V4L2_CID_EXPOSURE_ABSOLUTE: return &v.exposure_absolute;
    default: return nullptr;
  }
}

uint32_t control_flags(const ControlInfo& c, const ControlValues& v) {
  if (c.type == V4L2_CTRL_TYPE_CTRL_CLASS) return V4L2_CTRL_FLAG_READ_ONLY | V4L2_CTRL_FLAG_WRITE_ONLY;
  uint32_t flags = 0;
  if (c.id == V4L2_CID_WHITE_BALANCE_TEMPERATURE && v.white_balance_auto != 0) flags |= V4L2_CTRL_FLAG_INACTIVE;
  if (c.id == V4L2_CID_EXPOSURE_ABSOLUTE && v.exposure_auto != V4L2_EXPOSURE_MANUAL) flags |= V4L2_CTRL_FLAG_INACTIVE;
  if (c.id == V4L2_CID_AUTO_WHITE_BALANCE || c.id == V4L2_CID_EXPOSURE_AUTO) flags |= V4L2_CTRL_FLAG_UPDATE;
  return flags;
}

// The control `id` refers to, with V4L2_CTRL_FLAG_NEXT_CTRL: the first one after it. -1: none.
int find_control(uint32_t id) {
  if ((id & V4L2_CTRL_FLAG_NEXT_CTRL) != 0) {
    const uint32_t after = id & ~(V4L2_CTRL_FLAG_NEXT_CTRL | V4L2_CTRL_FLAG_NEXT_COMPOUND);
    for (int i = 0; i < control_count(); ++i) {
      if (control_at(i, 30).id > after) return i;
    }
    return -1;
  }
  return control_index(id);
}

// Validates and clamps `value` for control `c` as the control framework does: integers are clamped
// to the range, booleans become 0/1, a menu value outside the menu's range is ERANGE, a skipped item EINVAL.
int check_value(const ControlInfo& c, int32_t& value) {
  switch (c.type) {
    case V4L2_CTRL_TYPE_BOOLEAN:
      value = value != 0 ? 1 : 0;
      return 0;
    case V4L2_CTRL_TYPE_MENU:
      if (value < c.minimum || value > c.maximum) return ERANGE;
      if (exposure_menu_name(value) == nullptr) return EINVAL;  // a skipped item
      return 0;
    case V4L2_CTRL_TYPE_INTEGER:
      value = std::clamp(value, c.minimum, c.maximum);
      return 0;
    default:
      return EACCES;
  }
}

// ---- control events ---------------------------------------------------------------------------

// Now on the program's CLOCK_MONOTONIC (lockstep: simulation time on it), as the kernel stamps events.
timespec event_time() {
  timespec now{};
  if (lockstep()) {
    const int64_t ns = g_monotonic_offset_ns + g_sim_now();
    now.tv_sec = static_cast<time_t>(ns / 1000000000);
    now.tv_nsec = static_cast<long>(ns % 1000000000);
  } else {
    ::clock_gettime(CLOCK_MONOTONIC, &now);
  }
  return now;
}

v4l2_event control_event(Camera& cam, int index, uint32_t changes) {
  const ControlInfo c = control_at(index, cam.source.fps);
  v4l2_event ev{};
  ev.type = V4L2_EVENT_CTRL;
  ev.id = c.id;
  ev.u.ctrl.changes = changes;
  ev.u.ctrl.type = c.type;
  const int32_t* value = control_value(cam.controls, c.id);
  ev.u.ctrl.value64 = value != nullptr ? *value : 0;  // a class control has none
  ev.u.ctrl.flags = control_flags(c, cam.controls);
  ev.u.ctrl.minimum = c.minimum;
  ev.u.ctrl.maximum = c.maximum;
  ev.u.ctrl.step = c.step;
  ev.u.ctrl.default_value = c.default_value;
  return ev;
}

Subscription* subscription_of(File& file, uint32_t id) {
  for (Subscription& s : file.subscriptions) {
    if (s.id == id) return &s;
  }
  return nullptr;
}

// Queues `ev` for `file`'s subscription `sub` (v4l2-event.c: one event per subscription, a newer one
// replacing the waiting one with both change bits, stamped and numbered when queued). Caller holds
// the camera's lock.
void queue_event(File& file, Subscription& sub, v4l2_event ev) {
  ev.sequence = file.sequence++;
  ev.timestamp = event_time();
  if (sub.waiting) {
    ev.u.ctrl.changes |= sub.event.u.ctrl.changes;
    file.waiting.erase(std::find(file.waiting.begin(), file.waiting.end(), sub.id));
  }
  sub.event = ev;
  sub.waiting = true;
  file.waiting.push_back(sub.id);
  if (file.waiting.size() == 1) eventfd_set(file.event_fd);
  file.camera->changed.notify_all();  // a blocking DQEVENT
}

// A change of control `index` to every descriptor of the camera subscribed to it, except `setter`
// when it did not ask for its own changes (V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK). Caller holds the
// camera's lock.
void send_control_event(Camera& cam, int index, uint32_t changes, const File* setter) {
  const v4l2_event ev = control_event(cam, index, changes);
  std::lock_guard tables(g_mutex);
  for (const auto& [fd, file] : g_files) {
    if (file->camera != &cam) continue;
    Subscription* sub = subscription_of(*file, ev.id);
    if (sub == nullptr || (file == setter && (sub->flags & V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK) == 0)) continue;
    queue_event(*file, *sub, ev);
  }
}

int subscribe_event(File& file, const v4l2_event_subscription& request) {
  if (request.type != V4L2_EVENT_CTRL) return fail(EINVAL);  // the only events a camera of doppel raises
  const int index = control_index(request.id);
  if (index < 0) return fail(EINVAL);
  Camera& cam = *file.camera;
  std::lock_guard lock(cam.mutex);
  if (file.event_fd < 0) {
    file.event_fd = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (file.event_fd < 0) return -1;
  }
  if (subscription_of(file, request.id) != nullptr) return 0;  // subscribed already: no second initial event
  Subscription& sub = file.subscriptions.emplace_back();
  sub.id = request.id;
  sub.flags = request.flags & (V4L2_EVENT_SUB_FL_SEND_INITIAL | V4L2_EVENT_SUB_FL_ALLOW_FEEDBACK);
  // The initial event: the control's state, except for a class control, which has none.
  if ((request.flags & V4L2_EVENT_SUB_FL_SEND_INITIAL) != 0 && control_at(index, cam.source.fps).type != V4L2_CTRL_TYPE_CTRL_CLASS) {
    queue_event(file, sub, control_event(cam, index, V4L2_EVENT_CTRL_CH_VALUE | V4L2_EVENT_CTRL_CH_FLAGS));
  }
  return 0;
}

// V4L2_EVENT_ALL ends every subscription; one that does not exist is no error (v4l2-event.c).
int unsubscribe_event(File& file, const v4l2_event_subscription& request) {
  Camera& cam = *file.camera;
  std::lock_guard lock(cam.mutex);
  const bool had_waiting = !file.waiting.empty();
  for (auto it = file.subscriptions.begin(); it != file.subscriptions.end();) {
    const bool ends = request.type == V4L2_EVENT_ALL || (request.type == V4L2_EVENT_CTRL && request.id == it->id);
    if (!ends) {
      ++it;
      continue;
    }
    if (it->waiting) file.waiting.erase(std::find(file.waiting.begin(), file.waiting.end(), it->id));
    it = file.subscriptions.erase(it);
  }
  if (had_waiting && file.waiting.empty()) eventfd_clear(file.event_fd);
  return 0;
}

int dequeue_event(File& file, v4l2_event* ev) {
  Camera& cam = *file.camera;
  const bool nonblocking = (::fcntl(file.fd, F_GETFL) & O_NONBLOCK) != 0;
  std::unique_lock lock(cam.mutex);
  while (file.waiting.empty()) {
    if (nonblocking) return fail(ENOENT);
    if (lockstep()) return fail(EAGAIN);  // the shim waits in simulation time and asks again
    cam.changed.wait(lock);
  }
  Subscription& sub = *subscription_of(file, file.waiting.front());
  file.waiting.pop_front();
  if (file.waiting.empty()) eventfd_clear(file.event_fd);
  sub.waiting = false;
  *ev = sub.event;
  ev->pending = static_cast<uint32_t>(file.waiting.size());
  return 0;
}

// Sets control `index` to `value` (checked) for `setter`, and tells the subscribers what changed:
// the value, and the flags of the controls an automatic one makes inactive. Caller holds the
// camera's lock.
void apply_control(Camera& cam, int index, int32_t value, const File* setter) {
  const ControlInfo c = control_at(index, cam.source.fps);
  int32_t* slot = control_value(cam.controls, c.id);
  if (*slot == value) return;
  std::vector<uint32_t> flags_before;
  for (int i = 0; i < control_count(); ++i) flags_before.push_back(control_flags(control_at(i, cam.source.fps), cam.controls));
  *slot = value;
  cam.curves = tone_curves(cam.controls, cam.source.fps, cam.source.format);
  if (c.id == V4L2_CID_AUTO_WHITE_BALANCE || c.id == V4L2_CID_WHITE_BALANCE_TEMPERATURE) white_balance_changed(cam);
  send_control_event(cam, index, V4L2_EVENT_CTRL_CH_VALUE, setter);
  for (int i = 0; i < control_count(); ++i) {
    if (control_flags(control_at(i, cam.source.fps), cam.controls) != flags_before[static_cast<std::size_t>(i)]) {
      send_control_event(cam, i, V4L2_EVENT_CTRL_CH_FLAGS, nullptr);  // the framework sends these to everyone
    }
  }
}

int ext_controls(File& file, unsigned long request, v4l2_ext_controls* ec) {
  Camera& cam = *file.camera;
  const uint32_t which = ec->which;
  if (which != V4L2_CTRL_WHICH_CUR_VAL && which != V4L2_CTRL_WHICH_DEF_VAL && which != V4L2_CTRL_CLASS_USER &&
      which != V4L2_CTRL_CLASS_CAMERA) {
    return fail(EINVAL);
  }
  if (ec->count == 0) return 0;
  if (ec->controls == nullptr) return fail(EFAULT);
  if (ec->count > 1024) return fail(E2BIG);
  const bool get = request == VIDIOC_G_EXT_CTRLS;
  const bool set = request == VIDIOC_S_EXT_CTRLS;
  if (!get && which == V4L2_CTRL_WHICH_DEF_VAL) {
    ec->error_idx = ec->count;
    return fail(EINVAL);
  }
  std::unique_lock lock(cam.mutex);
  // Check every control first (the spec: nothing is changed when one is wrong).
  for (uint32_t i = 0; i < ec->count; ++i) {
    v4l2_ext_control& x = ec->controls[i];
    const int index = control_index(x.id);
    const ControlInfo c = control_at(index, cam.source.fps);
    const bool class_ok = which == V4L2_CTRL_WHICH_CUR_VAL || which == V4L2_CTRL_WHICH_DEF_VAL ||
                          V4L2_CTRL_ID2WHICH(x.id) == which;
    // Class controls are write-only for G and read-only for S/TRY (EACCES); unknown ids EINVAL.
    // error_idx: count for G and S (nothing was touched), the control's index for TRY.
    if (index < 0 || !class_ok || c.type == V4L2_CTRL_TYPE_CTRL_CLASS) {
      ec->error_idx = get || set ? ec->count : i;
      return fail(index >= 0 && class_ok ? EACCES : EINVAL);
    }
    if (!get) {
      int32_t value = x.value;
      if (const int error = check_value(c, value)) {
        ec->error_idx = i;
        return fail(error);
      }
    }
  }
  if (set && outranked(file)) {
    ec->error_idx = ec->count;
    return fail(EBUSY);
  }
  for (uint32_t i = 0; i < ec->count; ++i) {
    v4l2_ext_control& x = ec->controls[i];
    const int index = control_index(x.id);
    const ControlInfo c = control_at(index, cam.source.fps);
    if (get) {
      x.value = which == V4L2_CTRL_WHICH_DEF_VAL ? c.default_value : *control_value(cam.controls, c.id);
      continue;
    }
    int32_t value = x.value;
    check_value(c, value);
    x.value = value;
    if (set) apply_control(cam, index, value, &file);
  }
  return 0;
}

// ---- ioctls ----------------------------------------------------------------------------------

bool capture_type(uint32_t type) { return type == V4L2_BUF_TYPE_VIDEO_CAPTURE; }

void fill_pix(const Mode& m, v4l2_pix_format& pix) {
  pix = {};
  pix.width = static_cast<uint32_t>(m.width);
  pix.height = static_cast<uint32_t>(m.height);
  pix.pixelformat = m.fourcc;
  pix.field = V4L2_FIELD_NONE;
  pix.bytesperline = m.bytesperline;
  pix.sizeimage = m.sizeimage;
  const bool yuv = m.fourcc == V4L2_PIX_FMT_YUYV || m.fourcc == V4L2_PIX_FMT_UYVY;
  pix.colorspace = yuv ? V4L2_COLORSPACE_SMPTE170M : (m.fourcc == V4L2_PIX_FMT_RGB24 ? V4L2_COLORSPACE_SRGB : V4L2_COLORSPACE_RAW);
  pix.ycbcr_enc = yuv ? V4L2_YCBCR_ENC_601 : V4L2_YCBCR_ENC_DEFAULT;
  pix.quantization = yuv ? V4L2_QUANTIZATION_LIM_RANGE : V4L2_QUANTIZATION_FULL_RANGE;
  pix.xfer_func = yuv ? V4L2_XFER_FUNC_709 : (m.fourcc == V4L2_PIX_FMT_RGB24 ? V4L2_XFER_FUNC_SRGB : V4L2_XFER_FUNC_NONE);
  if (!yuv && m.fourcc != V4L2_PIX_FMT_RGB24) pix.ycbcr_enc = V4L2_YCBCR_ENC_DEFAULT;
}

void fill_buffer(const Camera& cam, uint32_t index, v4l2_buffer& out) {
  const Buffer& b = cam.buffers[index];
  const uint32_t type = out.type;
  const uint32_t memory = cam.memory;
  out = {};
  out.index = index;
  out.type = type;
  out.memory = memory;
  out.field = V4L2_FIELD_NONE;
  out.flags = kTimestampFlags | b.flags;
  if (b.mappings > 0) out.flags |= V4L2_BUF_FLAG_MAPPED;
  if (b.state == BufferState::kQueued || b.state == BufferState::kFilling) out.flags |= V4L2_BUF_FLAG_QUEUED;
  if (b.state == BufferState::kDone) out.flags |= V4L2_BUF_FLAG_DONE;
  if (memory == V4L2_MEMORY_MMAP) {
    out.m.offset = index * cam.buffer_stride;
    out.length = cam.mode.sizeimage;
  } else {
    out.m.userptr = b.userptr;
    out.length = b.user_length != 0 ? b.user_length : cam.mode.sizeimage;
  }
  if (b.state == BufferState::kDone || b.state == BufferState::kDequeued) {
    out.bytesused = b.bytesused;
    out.sequence = b.sequence;
    out.timestamp = b.timestamp;
  }
}

int reqbufs(File& file, v4l2_requestbuffers* rb) {
  Camera& cam = *file.camera;
  if (!capture_type(rb->type)) return fail(EINVAL);
  if (rb->memory != V4L2_MEMORY_MMAP && rb->memory != V4L2_MEMORY_USERPTR) return fail(EINVAL);
  memset(rb->reserved, 0, sizeof(rb->reserved));
  rb->capabilities = V4L2_BUF_CAP_SUPPORTS_MMAP | V4L2_BUF_CAP_SUPPORTS_USERPTR | V4L2_BUF_CAP_SUPPORTS_ORPHANED_BUFS;
  rb->flags = 0;
  std::unique_lock lock(cam.mutex);
  if (cam.owner != nullptr && cam.owner != &file) return fail(EBUSY);
  if (outranked(file)) return fail(EBUSY);
  if (cam.reading) return fail(EBUSY);
  if (cam.streaming) return fail(EBUSY);
  free_buffers(cam);
  if (rb->count == 0) {
    cam.owner = nullptr;
    return 0;
  }
  const uint32_t count = std::clamp(rb->count, kMinBuffers, kMaxBuffers);
  const long page = sysconf(_SC_PAGESIZE);
  cam.memory = rb->memory;
  cam.buffer_stride = static_cast<uint32_t>((cam.mode.sizeimage + page - 1) / page * page);
  if (rb->memory == V4L2_MEMORY_MMAP) {
    const size_t total = static_cast<size_t>(cam.buffer_stride) * count;
    cam.memfd = static_cast<int>(syscall(SYS_memfd_create, "doppel-v4l2", MFD_CLOEXEC));
    if (cam.memfd < 0 || ::ftruncate(cam.memfd, static_cast<off_t>(total)) != 0) {
      free_buffers(cam);
      return fail(ENOMEM);
    }
    void* base = ::mmap(nullptr, total, PROT_READ | PROT_WRITE, MAP_SHARED, cam.memfd, 0);
    if (base == MAP_FAILED) {
      free_buffers(cam);
      return fail(ENOMEM);
    }
    cam.memory_base = static_cast<uint8_t*>(base);
  }
  cam.buffers.assign(count, Buffer{});
  cam.owner = &file;
  rb->count = count;
  return 0;
}

// True when [address, address + length) is mapped memory of this process (mincore fails with
// ENOMEM on any unmapped page), as get_user_pages checks a USERPTR buffer.
bool user_memory_mapped(unsigned long address, uint32_t length) {
  const long page = sysconf(_SC_PAGESIZE);
  const unsigned long first = address / static_cast<unsigned long>(page) * static_cast<unsigned long>(page);
  const size_t span = address + length - first;
  unsigned char pages[8192];
  if (span / static_cast<size_t>(page) + 1 > sizeof(pages)) return false;
  return ::mincore(reinterpret_cast<void*>(first), span, pages) == 0;
}

int qbuf(File& file, v4l2_buffer* b) {
  Camera& cam = *file.camera;
  std::unique_lock lock(cam.mutex);
  if (!capture_type(b->type)) return fail(EINVAL);
  if (cam.owner != &file || cam.reading) return fail(cam.owner == nullptr ? EINVAL : EBUSY);
  if (b->memory != cam.memory || b->index >= cam.buffers.size()) return fail(EINVAL);
  if ((b->flags & V4L2_BUF_FLAG_REQUEST_FD) != 0) return fail(EBADR);
  Buffer& buf = cam.buffers[b->index];
  if (buf.state != BufferState::kDequeued) return fail(EINVAL);
  if (cam.memory == V4L2_MEMORY_USERPTR) {
    if (b->m.userptr == 0 || b->length < cam.mode.sizeimage) return fail(EINVAL);
    if (!user_memory_mapped(b->m.userptr, b->length)) return fail(EFAULT);
    buf.userptr = b->m.userptr;
    buf.user_length = b->length;
  }
  buf.state = BufferState::kQueued;
  buf.flags = 0;
  cam.queued.push_back(b->index);
  fill_buffer(cam, b->index, *b);
  return 0;
}

int dqbuf(File& file, v4l2_buffer* b) {
  Camera& cam = *file.camera;
  std::unique_lock lock(cam.mutex);
  if (!capture_type(b->type)) return fail(EINVAL);
  if (cam.owner != &file || cam.reading) return fail(cam.owner == nullptr ? EINVAL : EBUSY);
  if (b->memory != cam.memory) return fail(EINVAL);
  const bool nonblocking = (::fcntl(file.fd, F_GETFL) & O_NONBLOCK) != 0;
  pump_camera(cam, lock);
  for (;;) {
    if (!cam.streaming) return fail(EINVAL);
    if (!cam.done.empty()) break;
    if (nonblocking || lockstep()) return fail(EAGAIN);  // lockstep: the shim waits in simulation time
    cam.changed.wait(lock);
  }
  const uint32_t index = cam.done.front();
  cam.done.pop_front();
  if (cam.done.empty()) eventfd_clear(file.fd);
  cam.buffers[index].state = BufferState::kDequeued;
  fill_buffer(cam, index, *b);
  return 0;
}

int streamon(File& file, const int* type, bool on) {
  Camera& cam = *file.camera;
  if (type == nullptr) return fail(EFAULT);
  if (!capture_type(static_cast<uint32_t>(*type))) return fail(EINVAL);
  std::unique_lock lock(cam.mutex);
  if (cam.owner == nullptr) return on ? fail(EINVAL) : 0;  // vb2: no buffers to start; stopping is fine
  if (cam.owner != &file || cam.reading) return fail(EBUSY);
  if (!on) {
    stream_off(cam, lock);
    return 0;
  }
  if (cam.streaming) return 0;
  if (cam.buffers.empty()) return fail(EINVAL);
  cam.streaming = true;
  if (start_worker(cam) != 0) {
    cam.streaming = false;
    return -1;
  }
  return 0;
}

int set_format(File& file, v4l2_format* f, bool apply) {
  Camera& cam = *file.camera;
  if (!capture_type(f->type)) return fail(EINVAL);
  const Mode m = nearest_mode(cam.source, f->fmt.pix.pixelformat, static_cast<int>(f->fmt.pix.width),
                              static_cast<int>(f->fmt.pix.height));
  std::unique_lock lock(cam.mutex);
  if (apply) {
    if (outranked(file)) return fail(EBUSY);
    if (!cam.buffers.empty() || cam.reading) {
      if (m.fourcc != cam.mode.fourcc || m.width != cam.mode.width || m.height != cam.mode.height) return fail(EBUSY);
    }
    cam.mode = m;
  }
  fill_pix(m, f->fmt.pix);
  return 0;
}

int parm(File& file, v4l2_streamparm* p, bool set) {
  Camera& cam = *file.camera;
  if (!capture_type(p->type)) return fail(EINVAL);
  if (set && outranked(file)) return fail(EBUSY);
  const uint32_t readbuffers = kMinBuffers;
  p->parm.capture = {};
  p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
  p->parm.capture.timeperframe = frame_interval(cam.source.fps);
  p->parm.capture.readbuffers = readbuffers;
  return 0;
}

int querycap(File& file, v4l2_capability* cap) {
  *cap = {};
  snprintf(reinterpret_cast<char*>(cap->driver), sizeof(cap->driver), "doppel");
  snprintf(reinterpret_cast<char*>(cap->card), sizeof(cap->card), "%s", file.camera->name.c_str());
  snprintf(reinterpret_cast<char*>(cap->bus_info), sizeof(cap->bus_info), "platform:doppel-%.6s", file.camera->name.c_str());
  utsname u{};
  unsigned major = 6, minor = 0, patch = 0;
  if (::uname(&u) == 0) sscanf(u.release, "%u.%u.%u", &major, &minor, &patch);
  cap->version = (major << 16) | (minor << 8) | std::min(patch, 255u);
  cap->device_caps = kCaps;
  cap->capabilities = kCaps | V4L2_CAP_DEVICE_CAPS;
  return 0;
}

int queryctrl(File& file, v4l2_queryctrl* q) {
  const int index = find_control(q->id);
  if (index < 0) return fail(EINVAL);
  Camera& cam = *file.camera;
  const ControlInfo c = control_at(index, cam.source.fps);
  std::lock_guard lock(cam.mutex);
  *q = {};
  q->id = c.id;
  q->type = c.type;
  snprintf(reinterpret_cast<char*>(q->name), sizeof(q->name), "%s", c.name);
  q->minimum = c.minimum;
  q->maximum = c.maximum;
  q->step = c.step;
  q->default_value = c.default_value;
  q->flags = control_flags(c, cam.controls);
  return 0;
}

int query_ext_ctrl(File& file, v4l2_query_ext_ctrl* q) {
  const int index = find_control(q->id);
  if (index < 0) return fail(EINVAL);
  Camera& cam = *file.camera;
  const ControlInfo c = control_at(index, cam.source.fps);
  std::lock_guard lock(cam.mutex);
  *q = {};
  q->id = c.id;
  q->type = c.type;
  snprintf(q->name, sizeof(q->name), "%s", c.name);
  q->minimum = c.minimum;
  q->maximum = c.maximum;
  q->step = static_cast<uint64_t>(c.step);
  q->default_value = c.default_value;
  q->flags = control_flags(c, cam.controls);
  if (c.type != V4L2_CTRL_TYPE_CTRL_CLASS) {
    q->elem_size = sizeof(int32_t);
    q->elems = 1;
  }
  return 0;
}

bool served(unsigned long request) {
  switch (request) {
    case VIDIOC_QUERYCAP: case VIDIOC_ENUM_FMT: case VIDIOC_G_FMT: case VIDIOC_S_FMT: case VIDIOC_TRY_FMT:
    case VIDIOC_ENUM_FRAMESIZES: case VIDIOC_ENUM_FRAMEINTERVALS: case VIDIOC_G_PARM: case VIDIOC_S_PARM:
    case VIDIOC_ENUMINPUT: case VIDIOC_G_INPUT: case VIDIOC_S_INPUT: case VIDIOC_G_PRIORITY: case VIDIOC_S_PRIORITY:
    case VIDIOC_REQBUFS: case VIDIOC_QUERYBUF: case VIDIOC_QBUF: case VIDIOC_DQBUF: case VIDIOC_STREAMON:
    case VIDIOC_STREAMOFF: case VIDIOC_QUERYCTRL: case VIDIOC_QUERY_EXT_CTRL: case VIDIOC_QUERYMENU: case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL: case VIDIOC_G_EXT_CTRLS: case VIDIOC_S_EXT_CTRLS: case VIDIOC_TRY_EXT_CTRLS: case VIDIOC_LOG_STATUS:
    case VIDIOC_SUBSCRIBE_EVENT: case VIDIOC_UNSUBSCRIBE_EVENT: case VIDIOC_DQEVENT:
      return true;
    default:
      return false;
  }
}

int do_ioctl(File& file, unsigned long request, void* arg) {
  Camera& cam = *file.camera;
  if (!served(request)) return fail(ENOTTY);  // before the argument: the V4L2 core's order
  if (arg == nullptr && request != VIDIOC_LOG_STATUS) return fail(EFAULT);
  switch (request) {
    case VIDIOC_QUERYCAP:
      return querycap(file, static_cast<v4l2_capability*>(arg));
    case VIDIOC_ENUM_FMT: {
      auto* f = static_cast<v4l2_fmtdesc*>(arg);
      if (!capture_type(f->type) || f->index >= static_cast<uint32_t>(format_count(cam.source)) || f->mbus_code != 0) {
        return fail(EINVAL);
      }
      const uint32_t index = f->index;
      const uint32_t type = f->type;
      *f = {};
      f->index = index;
      f->type = type;
      f->pixelformat = format_at(cam.source, static_cast<int>(index));
      const uint32_t pf = f->pixelformat;
      const char* description = pf == V4L2_PIX_FMT_YUYV   ? "YUYV 4:2:2"
                                : pf == V4L2_PIX_FMT_UYVY  ? "UYVY 4:2:2"
                                : pf == V4L2_PIX_FMT_RGB24 ? "24-bit RGB 8-8-8"
                                : pf == V4L2_PIX_FMT_SRGGB8 ? "8-bit Bayer RGRG/GBGB"
                                : pf == V4L2_PIX_FMT_SBGGR8 ? "8-bit Bayer BGBG/GRGR"
                                : pf == V4L2_PIX_FMT_SGRBG8 ? "8-bit Bayer GRGR/BGBG"
                                                            : "8-bit Bayer GBGB/RGRG";
      snprintf(reinterpret_cast<char*>(f->description), sizeof(f->description), "%s", description);
      return 0;
    }
    case VIDIOC_G_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      if (!capture_type(f->type)) return fail(EINVAL);
      std::lock_guard lock(cam.mutex);
      fill_pix(cam.mode, f->fmt.pix);
      return 0;
    }
    case VIDIOC_S_FMT:
      return set_format(file, static_cast<v4l2_format*>(arg), true);
    case VIDIOC_TRY_FMT:
      return set_format(file, static_cast<v4l2_format*>(arg), false);
    case VIDIOC_ENUM_FRAMESIZES: {
      auto* s = static_cast<v4l2_frmsizeenum*>(arg);
      if (s->index >= static_cast<uint32_t>(size_count(cam.source, s->pixel_format))) return fail(EINVAL);
      const Mode m = mode_at(cam.source, s->pixel_format, static_cast<int>(s->index));
      memset(s->reserved, 0, sizeof(s->reserved));
      s->type = V4L2_FRMSIZE_TYPE_DISCRETE;
      s->discrete.width = static_cast<uint32_t>(m.width);
      s->discrete.height = static_cast<uint32_t>(m.height);
      return 0;
    }
    case VIDIOC_ENUM_FRAMEINTERVALS: {
      auto* i = static_cast<v4l2_frmivalenum*>(arg);
      bool size_ok = false;
      for (int k = 0; k < size_count(cam.source, i->pixel_format); ++k) {
        const Mode m = mode_at(cam.source, i->pixel_format, k);
        size_ok = size_ok || (static_cast<uint32_t>(m.width) == i->width && static_cast<uint32_t>(m.height) == i->height);
      }
      if (i->index != 0 || !size_ok) return fail(EINVAL);
      memset(i->reserved, 0, sizeof(i->reserved));
      i->type = V4L2_FRMIVAL_TYPE_DISCRETE;
      i->discrete = frame_interval(cam.source.fps);
      return 0;
    }
    case VIDIOC_G_PARM:
      return parm(file, static_cast<v4l2_streamparm*>(arg), false);
    case VIDIOC_S_PARM:
      return parm(file, static_cast<v4l2_streamparm*>(arg), true);
    case VIDIOC_ENUMINPUT: {
      auto* in = static_cast<v4l2_input*>(arg);
      if (in->index != 0) return fail(EINVAL);
      *in = {};
      snprintf(reinterpret_cast<char*>(in->name), sizeof(in->name), "Camera");
      in->type = V4L2_INPUT_TYPE_CAMERA;
      return 0;
    }
    case VIDIOC_G_INPUT:
      *static_cast<int*>(arg) = 0;
      return 0;
    case VIDIOC_S_INPUT:
      return *static_cast<int*>(arg) == 0 ? 0 : fail(EINVAL);
    case VIDIOC_G_PRIORITY:
      *static_cast<uint32_t*>(arg) = max_priority(cam);
      return 0;
    case VIDIOC_S_PRIORITY: {
      const uint32_t p = *static_cast<uint32_t*>(arg);
      if (p > V4L2_PRIORITY_RECORD) return fail(EINVAL);
      const uint32_t wanted = p == V4L2_PRIORITY_UNSET ? static_cast<uint32_t>(V4L2_PRIORITY_DEFAULT) : p;
      if (wanted < file.priority) {
        file.priority = wanted;
        return 0;
      }
      std::lock_guard lock(g_mutex);
      for (const auto& [fd, other] : g_files) {
        if (other != &file && other->camera == &cam && other->priority == V4L2_PRIORITY_RECORD) return fail(EBUSY);
      }
      file.priority = wanted;
      return 0;
    }
    case VIDIOC_REQBUFS:
      return reqbufs(file, static_cast<v4l2_requestbuffers*>(arg));
    case VIDIOC_QUERYBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      std::lock_guard lock(cam.mutex);
      if (!capture_type(b->type) || b->index >= cam.buffers.size()) return fail(EINVAL);
      fill_buffer(cam, b->index, *b);
      return 0;
    }
    case VIDIOC_QBUF:
      return qbuf(file, static_cast<v4l2_buffer*>(arg));
    case VIDIOC_DQBUF:
      return dqbuf(file, static_cast<v4l2_buffer*>(arg));
    case VIDIOC_STREAMON:
      return streamon(file, static_cast<const int*>(arg), true);
    case VIDIOC_STREAMOFF:
      return streamon(file, static_cast<const int*>(arg), false);
    case VIDIOC_QUERYCTRL:
      return queryctrl(file, static_cast<v4l2_queryctrl*>(arg));
    case VIDIOC_QUERY_EXT_CTRL:
      return query_ext_ctrl(file, static_cast<v4l2_query_ext_ctrl*>(arg));
    case VIDIOC_QUERYMENU: {
      auto* m = static_cast<v4l2_querymenu*>(arg);
      const int index = control_index(m->id);
      const char* name = exposure_menu_name(static_cast<int32_t>(m->index));
      if (m->id != V4L2_CID_EXPOSURE_AUTO || index < 0 || name == nullptr) return fail(EINVAL);
      const uint32_t id = m->id, item = m->index;
      *m = {};
      m->id = id;
      m->index = item;
      snprintf(reinterpret_cast<char*>(m->name), sizeof(m->name), "%s", name);
      return 0;
    }
    case VIDIOC_G_CTRL:
    case VIDIOC_S_CTRL: {
      auto* c = static_cast<v4l2_control*>(arg);
      v4l2_ext_control x{};
      x.id = c->id;
      x.value = c->value;
      v4l2_ext_controls ec{};
      ec.which = V4L2_CTRL_WHICH_CUR_VAL;
      ec.count = 1;
      ec.controls = &x;
      const int r = ext_controls(file, request == VIDIOC_G_CTRL ? VIDIOC_G_EXT_CTRLS : VIDIOC_S_EXT_CTRLS, &ec);
      if (r == 0) c->value = x.value;
      return r;
    }
    case VIDIOC_G_EXT_CTRLS:
    case VIDIOC_S_EXT_CTRLS:
    case VIDIOC_TRY_EXT_CTRLS:
      return ext_controls(file, request, static_cast<v4l2_ext_controls*>(arg));
    case VIDIOC_SUBSCRIBE_EVENT:
      return subscribe_event(file, *static_cast<const v4l2_event_subscription*>(arg));
    case VIDIOC_UNSUBSCRIBE_EVENT:
      return unsubscribe_event(file, *static_cast<const v4l2_event_subscription*>(arg));
    case VIDIOC_DQEVENT:
      return dequeue_event(file, static_cast<v4l2_event*>(arg));
    case VIDIOC_LOG_STATUS:
      say(cam.name + ": " + std::to_string(cam.mode.width) + "x" + std::to_string(cam.mode.height) +
          (cam.streaming ? ", streaming" : ", not streaming"));
      return 0;
    default:
      return fail(ENOTTY);
  }
}

// ---- the C interface -------------------------------------------------------------------------

int api_open(const char* device, const char* camera_name, int flags) {
  try {
    errno = ENODEV;
    Camera* cam = camera_for(device, camera_name);
    if (cam == nullptr) return -1;  // ENOENT: no such camera; ENODEV: unusable
    const int fd = ::eventfd(0, ((flags & O_NONBLOCK) != 0 ? EFD_NONBLOCK : 0) | ((flags & O_CLOEXEC) != 0 ? EFD_CLOEXEC : 0));
    if (fd < 0) return -1;
    auto* file = new File;
    file->fd = fd;
    file->camera = cam;
    std::lock_guard lock(g_mutex);
    g_files[fd] = file;
    return fd;
  } catch (const std::exception& e) {
    say(std::string(device) + ": " + e.what());
    return fail(ENODEV);
  }
}

int api_close(int fd) {
  File* file = nullptr;
  {
    std::lock_guard lock(g_mutex);
    const auto it = g_files.find(fd);
    if (it != g_files.end()) {
      file = it->second;
      g_files.erase(it);
    }
  }
  if (file != nullptr) {
    Camera& cam = *file->camera;
    std::unique_lock lock(cam.mutex);
    if (cam.owner == file) {
      stream_off(cam, lock);
      stop_reading(cam, lock);
      free_buffers(cam);
      cam.owner = nullptr;
    }
    if (file->event_fd >= 0) syscall(SYS_close, file->event_fd);
    lock.unlock();
    delete file;
  }
  return static_cast<int>(syscall(SYS_close, fd));
}

int api_ioctl(int fd, unsigned long request, void* arg) {
  File* file = file_of(fd);
  if (file == nullptr) return fail(EBADF);
  try {
    return do_ioctl(*file, request, arg);
  } catch (const std::exception& e) {
    say(file->camera->name + ": " + e.what());
    return fail(EIO);
  }
}

void* api_mmap(void* addr, size_t length, int prot, int flags, int fd, off_t offset) {
  File* file = file_of(fd);
  if (file == nullptr) {
    errno = EBADF;
    return MAP_FAILED;
  }
  Camera& cam = *file->camera;
  std::lock_guard lock(cam.mutex);
  // vb2_mmap: MMAP buffers only, a shared mapping, an offset naming a buffer, at most its length.
  if (cam.memory != V4L2_MEMORY_MMAP || cam.memfd < 0 || (flags & MAP_SHARED) == 0 || cam.buffer_stride == 0 ||
      offset < 0 || offset % cam.buffer_stride != 0 || static_cast<size_t>(offset / cam.buffer_stride) >= cam.buffers.size() ||
      length == 0 || length > cam.buffer_stride) {
    errno = EINVAL;
    return MAP_FAILED;
  }
  void* p = ::mmap(addr, length, prot, flags, cam.memfd, offset);
  if (p == MAP_FAILED) return p;
  const auto index = static_cast<uint32_t>(offset / cam.buffer_stride);
  cam.buffers[index].mappings++;
  std::lock_guard tables(g_mutex);
  g_mappings.push_back({reinterpret_cast<uintptr_t>(p), length, &cam, index});
  return p;
}

void api_unmapped(void* addr, size_t length) {
  const auto begin = reinterpret_cast<uintptr_t>(addr);
  Camera* cam = nullptr;
  uint32_t index = 0;
  {
    std::lock_guard lock(g_mutex);
    for (auto it = g_mappings.begin(); it != g_mappings.end(); ++it) {
      if (it->address >= begin && it->address < begin + length) {
        cam = it->camera;
        index = it->index;
        g_mappings.erase(it);
        break;
      }
    }
  }
  if (cam == nullptr) return;
  std::lock_guard lock(cam->mutex);
  if (index < cam->buffers.size() && cam->buffers[index].mappings > 0) cam->buffers[index].mappings--;
}

ssize_t api_read(int fd, void* out, size_t n) {
  File* file = file_of(fd);
  if (file == nullptr) return fail(EBADF);
  Camera& cam = *file->camera;
  std::unique_lock lock(cam.mutex);
  if (cam.owner != nullptr && cam.owner != file) return fail(EBUSY);
  if (!cam.reading) {
    if (!cam.buffers.empty()) return fail(EBUSY);
    if (outranked(*file)) return fail(EBUSY);
    cam.owner = file;
    cam.reading = true;
    if (start_worker(cam) != 0) {
      cam.reading = false;
      cam.owner = nullptr;
      return -1;
    }
  }
  const bool nonblocking = (::fcntl(fd, F_GETFL) & O_NONBLOCK) != 0;
  pump_camera(cam, lock);
  while (!cam.pending) {
    if (nonblocking || lockstep()) return fail(EAGAIN);  // lockstep: the shim waits in simulation time
    cam.changed.wait(lock);
  }
  camera::Frame frame = std::move(*cam.pending);
  cam.pending.reset();
  eventfd_clear(fd);
  const Mode mode = cam.mode;
  const ToneCurves curves = cam.curves;
  lock.unlock();
  if (n < mode.sizeimage) return fail(EINVAL);  // one whole frame per read
  if (!frame_matches(cam, frame.header())) return fail(EIO);
  convert_frame(cam.source, frame.pixels(), frame.header().stride_bytes, mode, curves, static_cast<uint8_t*>(out));
  return static_cast<ssize_t>(mode.sizeimage);
}

int api_event_fd(int fd) {
  File* file = file_of(fd);
  if (file == nullptr) return fail(EBADF);
  std::lock_guard lock(file->camera->mutex);
  return file->event_fd;
}

void api_set_lockstep(int64_t (*sim_now)(void), int64_t monotonic_offset_ns) {
  g_monotonic_offset_ns = monotonic_offset_ns;
  g_sim_now = sim_now;
}

void pump_one(Camera& cam) {
  std::unique_lock lock(cam.mutex);
  pump_camera(cam, lock);
}

void api_pump(int fd) {
  if (!lockstep()) return;
  if (fd >= 0) {
    if (File* file = file_of(fd)) pump_one(*file->camera);
    return;
  }
  std::vector<Camera*> cameras;  // not under g_mutex: a camera's lock is taken before it elsewhere
  {
    std::lock_guard lock(g_mutex);
    for (const auto& [name, cam] : g_cameras) cameras.push_back(cam);
  }
  for (Camera* cam : cameras) pump_one(*cam);
}

const DoppelV4l2Api g_api = {api_open, api_close, api_ioctl, api_mmap, api_unmapped,
                             api_read, api_set_lockstep, api_pump, api_event_fd};

}  // namespace
}  // namespace doppel::shim

extern "C" __attribute__((visibility("default"))) const DoppelV4l2Api* doppel_v4l2_api(void) { return &doppel::shim::g_api; }
