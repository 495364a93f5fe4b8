#pragma once
// iceoryx for this process, in one place. iceoryx needs its daemon, RouDi, which hands out the
// shared-memory pools and connects publishers to subscribers. A process that publishes (doppel's
// cameras, its truth transport) holds the one Host of the process: it starts RouDi inside the
// process (sized from the pools its users ask for) or, when a RouDi already runs on the machine (an
// iox-roudi or another doppel), registers with that one. A process that only subscribes
// (doppel-camera, doppel-truth, the V4L2 module) registers as a client instead. iceoryx types stay
// out of this header. Setup code throughout: nothing here is for a real-time thread.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace doppel::roudi {

enum class Mode : uint8_t {
  kAuto,       // use a RouDi already running on this machine, else start one in this process
  kInProcess,  // start RouDi in this process; fail if one already runs
  kExternal,   // use a running RouDi; fail if there is none
};

// Chunks of one size in the in-process RouDi's pools.
struct Pool {
  uint32_t payload_bytes = 0;  // a chunk's payload (iceoryx adds its chunk header)
  uint32_t chunks = 0;
};

struct HostOptions {
  Mode mode = Mode::kAuto;               // see Mode
  std::string runtime_name;              // iceoryx application name; empty = "doppel-<pid>"
  std::vector<Pool> pools;               // in-process: added to the small pools every host has
  double introspection_timeout_s = 3.0;  // external RouDi: how long to wait for its mempool report
  bool verbose = false;                  // also print iceoryx's own warnings and info lines
};

class Host {
 public:
  // The Host of this process, shared: the one that exists, or a new one brought up with `options`
  // (which apply only then). RouDi, when started here, stops with the last holder. Throws
  // std::runtime_error with the reason (RouDi already running in kInProcess, none in kExternal, a
  // running RouDi that does not report its pools, /dev/shm too small) and std::logic_error when this
  // process registered as a client (register_client) before.
  static std::shared_ptr<Host> share(const HostOptions& options);
  ~Host();
  Host(const Host&) = delete;
  Host& operator=(const Host&) = delete;

  bool in_process() const noexcept;
  // Largest chunk payload of the pools in use (in-process: its own; external: what the running
  // RouDi reports for this process' group, else for any).
  uint64_t max_payload_bytes() const noexcept;
  // In-process: payload bytes -> chunks of every pool, and the bytes they take with their headers.
  const std::map<uint32_t, uint32_t>& pools() const noexcept;
  uint64_t pool_bytes() const noexcept;
  // True while a Host exists in this process.
  static bool exists() noexcept;

  struct Impl;

 private:
  explicit Host(const HostOptions& options);
  std::unique_ptr<Impl> impl_;
};

// True when a RouDi (iox-roudi or a doppel) holds the machine-wide lock
// (/tmp/iox-unique-roudi.lock). Does not create the lock file.
bool running();

// iceoryx's own log lines: errors only, or (verbose) from info on, with the level announcement.
void set_log_level(bool verbose);

// True once this process registered with a running RouDi as a client; an iceoryx client runtime
// lasts until the process ends.
bool client_registered() noexcept;
// Registers this process with the running RouDi as `runtime_name`. Does nothing when this process
// already has iceoryx (a Host, or an earlier call). Check running() first: without a RouDi, iceoryx
// waits a minute and then aborts the process.
void register_client(const std::string& runtime_name);

}  // namespace doppel::roudi
