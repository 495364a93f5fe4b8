#include "roudi/host.h"

#include <fcntl.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "iceoryx_hoofs/cxx/generic_raii.hpp"
#include "iceoryx_hoofs/posix_wrapper/posix_access_rights.hpp"
#include "iceoryx_posh/iceoryx_posh_config.hpp"
#include "iceoryx_posh/iceoryx_posh_types.hpp"
// An internal header, on purpose: in iceoryx 2.0.3 iox::roudi::RouDi is the only way to run RouDi
// inside a process that goes on doing other work (iceoryx's own single-process example includes it
// too; the public IceOryxRouDiApp::run() blocks and takes over the signals). tests/camera's
// roudi_test.cpp pins the iceoryx version this was checked with, so another version fails a test
// before it is trusted.
#include "iceoryx_posh/internal/roudi/roudi.hpp"
#include "iceoryx_posh/internal/runtime/ipc_interface_base.hpp"
#include "iceoryx_posh/popo/subscriber.hpp"
#include "iceoryx_posh/roudi/iceoryx_roudi_components.hpp"
#include "iceoryx_posh/roudi/introspection_types.hpp"
#include "iceoryx_posh/runtime/posh_runtime.hpp"
#include "iceoryx_posh/runtime/posh_runtime_single_process.hpp"
#include "process.h"

namespace doppel::roudi {
namespace {

constexpr uint64_t kMgmtSegmentEstimateBytes = 80ull << 20;  // RouDi's management segment (~66 MB)

// The pools every in-process RouDi has besides its users' (payload bytes -> chunks): small ones for
// info topics, truth messages and other users.
constexpr Pool kBasePools[] = {{128, 1024}, {1024, 512}, {16384, 128}, {131072, 16}};

// The shared host and who may make it: one at a time, and a new one only after the last is gone.
std::mutex g_share_mutex;
std::weak_ptr<Host> g_shared;

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

struct Host::Impl {
  bool in_process = false;
  uint64_t max_payload = 0;
  std::map<uint32_t, uint32_t> pools;
  uint64_t pool_bytes = 0;
  std::unique_ptr<iox::roudi::IceOryxRouDiComponents> components;
  std::unique_ptr<iox::roudi::RouDi> roudi;
  std::unique_ptr<iox::runtime::PoshRuntimeSingleProcess> runtime;

  ~Impl() {
    runtime.reset();
    roudi.reset();
    components.reset();
  }
};

std::shared_ptr<Host> Host::share(const HostOptions& options) {
  const std::lock_guard<std::mutex> lock(g_share_mutex);
  if (std::shared_ptr<Host> host = g_shared.lock()) return host;
  std::shared_ptr<Host> host(new Host(options));
  g_shared = host;
  return host;
}

Host::Host(const HostOptions& options) {
  if (detail::g_client_runtime.load()) {
    throw std::logic_error("roudi::Host: this process already registered with RouDi as a client");
  }
  if (detail::g_host_alive.exchange(true)) {
    throw std::logic_error("roudi::Host: only one may exist per process");
  }
  try {
    set_log_level(options.verbose);
    impl_ = std::make_unique<Impl>();
    const std::string name =
        options.runtime_name.empty() ? "doppel-" + std::to_string(::getpid()) : options.runtime_name;
    const bool running_here = running();
    if (running_here && options.mode == Mode::kInProcess) {
      throw std::runtime_error("a RouDi already runs on this machine (an iox-roudi or another doppel); "
                               "use the external RouDi or stop it first");
    }
    if (!running_here && options.mode == Mode::kExternal) {
      throw std::runtime_error("no RouDi runs on this machine: start iox-roudi first or let doppel start its own");
    }

    if (!running_here) {
      for (const Pool& pool : kBasePools) impl_->pools[pool.payload_bytes] += pool.chunks;
      for (const Pool& pool : options.pools) impl_->pools[pool.payload_bytes] += pool.chunks;
      iox::mepoo::MePooConfig mepoo;
      for (const auto& [size, count] : impl_->pools) {
        mepoo.addMemPool({size, count});
        impl_->pool_bytes += (uint64_t{size} + 128) * count;
        impl_->max_payload = std::max<uint64_t>(impl_->max_payload, size);
      }
      struct statvfs shm {};
      if (::statvfs("/dev/shm", &shm) == 0) {
        const uint64_t free_bytes = static_cast<uint64_t>(shm.f_bavail) * shm.f_frsize;
        if (free_bytes < impl_->pool_bytes + kMgmtSegmentEstimateBytes) {
          throw std::runtime_error("/dev/shm has " + std::to_string(free_bytes >> 20) + " MiB free, RouDi needs about " +
                                   std::to_string((impl_->pool_bytes + kMgmtSegmentEstimateBytes) >> 20) +
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
    } else {
      iox::runtime::PoshRuntime::initRuntime(iox::RuntimeName_t(iox::cxx::TruncateToCapacity, name.c_str()));
      detail::g_client_runtime = true;
      impl_->max_payload = external_max_payload(options.introspection_timeout_s);
      if (impl_->max_payload == 0) {
        throw std::runtime_error("a RouDi runs on this machine but did not report its memory pools within " +
                                 std::to_string(options.introspection_timeout_s) + " s");
      }
    }
  } catch (...) {
    impl_.reset();
    detail::g_host_alive = false;
    throw;
  }
}

Host::~Host() {
  const std::lock_guard<std::mutex> lock(g_share_mutex);  // no new host until this one's RouDi is gone
  impl_.reset();
  detail::g_host_alive = false;
}

bool Host::in_process() const noexcept { return impl_->in_process; }
uint64_t Host::max_payload_bytes() const noexcept { return impl_->max_payload; }
const std::map<uint32_t, uint32_t>& Host::pools() const noexcept { return impl_->pools; }
uint64_t Host::pool_bytes() const noexcept { return impl_->pool_bytes; }
bool Host::exists() noexcept { return detail::g_host_alive.load(); }

}  // namespace doppel::roudi
