#pragma once
// A per-thread pool of memory blocks in power-of-two size classes, put in front of malloc for the
// engines (their allocation hooks are process-wide): blocks an engine frees are kept for its next
// request of the same class, and each thread's pool is stocked before its first step, so that the
// arrays an engine grows now and then during a step are served without calling malloc. Used by
// the backends only; not a general allocator (no size above 1 MiB is pooled, memory is never
// returned to the system).

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <new>

namespace doppel::physics {

class BlockPool {
 public:
  // A block of at least `size` bytes, 16-byte aligned. rt-safe once stocked (falls back to malloc).
  static void* allocate(size_t size) noexcept {
    const size_t cls = class_of(size + kHeader);
    void* raw = nullptr;
    if (cls < kClasses) {
      raw = local().pop(cls);
      if (raw == nullptr) raw = std::malloc(size_t{1} << cls);
    } else {
      raw = std::malloc(size + kHeader);
    }
    if (raw == nullptr) return nullptr;
    *static_cast<size_t*>(raw) = cls;
    return static_cast<char*>(raw) + kHeader;
  }

  // Returns a block from allocate(). rt-safe.
  static void release(void* block) noexcept {
    if (block == nullptr) return;
    void* raw = static_cast<char*>(block) - kHeader;
    const size_t cls = *static_cast<size_t*>(raw);
    if (cls < kClasses) {
      local().push(raw, cls);
    } else {
      std::free(raw);
    }
  }

  // Puts `count` blocks of every class from 32 B to 256 KiB into this thread's pool, once per
  // thread (allocates: call before the real-time loop, e.g. on a thread's first step).
  static void stock(size_t count) noexcept {
    Local& pool = local();
    if (pool.stocked) return;
    pool.stocked = true;
    for (size_t cls = 5; cls <= 18; ++cls) {
      for (size_t i = 0; i < count; ++i) {
        void* raw = std::malloc(size_t{1} << cls);
        if (raw != nullptr) pool.push(raw, cls);
      }
    }
  }

 private:
  static constexpr size_t kHeader = 16;   // keeps malloc's 16-byte alignment
  static constexpr size_t kClasses = 21;  // up to 1 MiB

  static size_t class_of(size_t bytes) noexcept {
    size_t cls = 4;
    while ((size_t{1} << cls) < bytes) ++cls;
    return cls;
  }

  struct Node {
    Node* next;
  };
  struct Local {
    std::array<Node*, kClasses> heads{};
    bool stocked = false;
    void* pop(size_t cls) noexcept {
      Node* node = heads[cls];
      if (node == nullptr) return nullptr;
      heads[cls] = node->next;
      return node;
    }
    void push(void* raw, size_t cls) noexcept { heads[cls] = new (raw) Node{heads[cls]}; }
  };
  static Local& local() noexcept {
    thread_local Local pool;
    return pool;
  }
};

}  // namespace doppel::physics
