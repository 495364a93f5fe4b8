#pragma once
// The serial port a servo-bus driver opens: the master side of a pseudo-terminal, published under a
// stable symlink (e.g. $XDG_RUNTIME_DIR/doppel/ttyDXL0 -> /dev/pts/N). Doppel never keeps the slave side open,
// so the kernel tells it when the last client has gone (the master reads EIO / polls POLLHUP).
// It is not a timing model and does not parse packets: BusServer does that on top of it.
//
// Client lifecycle (verified on Linux 6.x, see tests/bus/pty_port_test.cpp):
// - A pty keeps bytes across client sessions: what Doppel wrote and the client did not read is
//   handed to the *next* client that opens the slave, and writes to the master succeed while no
//   client is open. A master-side tcflush(TCOFLUSH) does not remove them (it only empties the
//   flip buffer). So on hang-up disconnect() opens the slave itself (TIOCGPTPEER), flushes its
//   input queue, restores raw mode if the old client left a mode that changes bytes (echo, line
//   editing, translations) and closes it again: the next open starts clean. When a new client has
//   opened since the hang-up, disconnect() touches nothing: a read-modify-write of the termios
//   would put the old rate back over the rate the new client just set (a driver that reopens the
//   port at another rate, as DynamixelSDK's setBaudRate does), and a flush could remove answers
//   already written to it. The termios are not written either when they are raw already.
// - Bytes a client wrote before closing are still readable before the EIO; the caller should read
//   them (complete packets did cross the wire) and drop only a trailing partial packet.
// - While nobody is connected the master polls POLLHUP permanently, so waiting for a client cannot
//   use poll on the master. wait_for_client() blocks on an inotify IN_OPEN watch on the slave
//   device instead: no CPU while idle and no added latency for the first packet. If inotify is
//   unavailable it falls back to sleeping ~1 ms between checks.
// - Hand-over counter: beside the link, `<link>.received` (base/pty_handover.h) counts the bytes
//   read from clients, so that doppel-run's preload library can let a write() return once Doppel
//   has the bytes, as a USB adapter's does (a pty leaves that to a kernel work item that a
//   real-time client can keep off its CPU). Created with the link, removed with it. The count
//   moves only when a read finds nothing left: that empty read waits (tty_buffer_flush_work) for
//   the work item that handed the bytes over. The work item wakes Doppel from inside itself, so
//   Doppel's real-time bus thread preempts it before it returns; were the client let go at once,
//   its busy-poll for the answer (the DARwIn-OP framework's SCHED_RR motion timer) would keep that
//   CPU, and Doppel's next poll of the master, which waits for the same work item, would answer
//   only after the client had timed out (seen with ftrace: a priority inversion). Doppel waits for
//   it while the client still sleeps in its write.
// - Known limit: a new client that opens the port within microseconds of the previous client's
//   last close, before the server thread has handled the hang-up, may receive bytes meant for its
//   predecessor (DynamixelSDK flushes its input before every transmission, which removes them).

#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

namespace doppel::bus {

struct PortWait {
  bool readable = false;  // bytes (or a hang-up) are waiting on the master
  bool writable = false;  // the client's input queue has room again
  bool hung_up = false;   // the last client closed the slave
};

// When the stable name appears. A driver (or a script watching the link directory) opens the port
// the moment the link exists and expects answers at once, as from a bus that is plugged in: a
// server publishes the link only once its thread serves the port (kOnPublish, then publish_link()).
enum class LinkTiming { kNow, kOnPublish };

class PtyPort final {
 public:
  // Opens a pty master (non-blocking, close-on-exec), puts the slave in raw mode and, with kNow,
  // points `link_path` at the slave, replacing an existing symlink (a stale link from an earlier
  // run). With kOnPublish it checks the link's place the same way and removes a stale link at
  // once; the link appears with publish_link(). The link's directory must exist (LinkDirectory
  // creates and checks it). Setup only. Throws std::runtime_error with the failing step and path
  // when a system call fails, the directory is missing, or `link_path` exists and is not a
  // symbolic link (it is never replaced then).
  explicit PtyPort(std::string link_path, LinkTiming timing = LinkTiming::kNow);
  // release_link(), saying on stderr when the link was replaced; closes the master.
  ~PtyPort();

  PtyPort(const PtyPort&) = delete;
  PtyPort& operator=(const PtyPort&) = delete;

  // Moves bytes only. read() copies up to `capacity` received bytes into `dst` and returns 0 when
  // nothing is waiting; on EIO (the client went away) it returns 0 and sets hung_up(); the bytes
  // read are published in the hand-over counter (`<link>.received`) by the read that returns 0, so
  // read until then. write()
  // returns the bytes accepted: 0 when the client's queue is full or no client is connected. Never
  // block. rt-safe.
  std::size_t read(uint8_t* dst, std::size_t capacity) noexcept;
  std::size_t write(const uint8_t* src, std::size_t n) noexcept;

  // Connected: waits up to `timeout_ns` (ns, >= 0) for input, a hang-up, or (want_write) room for
  // output. Not connected: the same as wait_for_client(). EINTR counts as a wake-up. rt-safe (no
  // allocation; it is a blocking system call, bounded by the timeout).
  PortWait wait(int64_t timeout_ns, bool want_write) noexcept;

  // Not connected: waits up to `timeout_ns` for a client to open the slave, then checks the line.
  // True when a client is connected (also returns at once if one already is). rt-safe.
  bool wait_for_client(int64_t timeout_ns) noexcept;

  // Checks without waiting whether a client holds the slave open or left bytes behind; switches to
  // connected if so. Returns connected(). rt-safe.
  bool poll_client() noexcept;

  // True between a client's open (as seen by poll_client / wait_for_client) and disconnect().
  bool connected() const noexcept { return connected_; }
  // True once read() or wait() has seen the last client close; cleared by disconnect().
  bool hung_up() const noexcept { return hung_up_; }

  // Ends the client session: discards every byte written for the old client that it did not read,
  // puts the slave back into raw mode and waits for the next open. Call after reading the
  // remaining input. rt-safe (system calls only).
  void disconnect() noexcept;

  // Line rate (bit/s) the client set on its end (Bxxxx or BOTHER, up to 4.5 Mbaud and beyond),
  // read with TCGETS2; 0 on error or B0. rt-safe.
  uint32_t line_baud_bps() const noexcept;

  // Points the link at the slave (atomically replacing a symlink that appeared meanwhile); the first
  // call acts, later ones and kNow ports do nothing. Setup only; throws as the constructor does.
  void publish_link();
  bool link_published() const noexcept { return link_published_; }

  enum class LinkRelease { kRemoved, kGone, kReplaced };
  // Removes the link if it is still this port's: a symlink owned by the user that points at
  // slave_path() (an unpublished link is not this port's: kGone). A link someone replaced is left alone (kReplaced), so its owner's device stays
  // reachable and the caller can report it. Only the first call acts; later ones return kGone.
  LinkRelease release_link() noexcept;

  int master_fd() const noexcept { return master_fd_; }
  const std::string& link_path() const noexcept { return link_path_; }    // the stable name
  const std::string& slave_path() const noexcept { return slave_path_; }  // /dev/pts/N
  // `<link>.received`: the hand-over counter of the port whose link is `link_path`.
  static std::string received_path_for_link(const std::string& link_path);
  // Bytes read from clients so far (what the hand-over file holds). rt-safe.
  uint64_t received() const noexcept { return received_total_; }

 private:
  // Opens the slave, sets raw mode if the last client left the line in a mode that changes bytes,
  // flushes the slave's input queue, closes it.
  void make_slave_raw_and_flush() noexcept;
  void drain_inotify() noexcept;
  void close_all() noexcept;
  void create_received_file();
  void remove_received_file() noexcept;

  std::string link_path_;
  std::string slave_path_;
  int master_fd_ = -1;
  int inotify_fd_ = -1;  // IN_OPEN watch on slave_path_, -1 when inotify is unavailable
  bool connected_ = false;
  bool hung_up_ = false;
  bool link_published_ = false;
  bool link_released_ = false;
  std::atomic<uint64_t>* received_ = nullptr;  // the mapped `<link>.received`
  uint64_t received_total_ = 0;
  int received_fd_ = -1;  // held open so the file created here can be told from a replacement
  dev_t received_dev_ = 0;
  ino_t received_ino_ = 0;
};

}  // namespace doppel::bus
