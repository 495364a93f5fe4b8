#pragma once
// The parts doppel runs (buses, world, cameras, control, recorder, ...) as components with one
// lifecycle, kept in one ordered list, as ros2_control's hardware components: configure builds
// and opens (ports, links, files, sockets: what allocates or may fail), start starts threads,
// stop joins them, release frees what configure made. Components are configured and started in
// list order and stopped and released in reverse, so the order lives in one place instead of in
// comments on member declarations. A failure in configure releases what was configured, a failure
// in start stops what started, each in reverse order, before the error goes on to the caller. The
// failing component is released (stopped) too, so that it can undo what it did before it failed:
// stop and release must cope with a component that never or only partly configured or started.

#include <cstddef>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace doppel::gateway {

enum class Transition { kConfigure, kStart, kStop, kRelease };

std::string_view transition_name(Transition transition) noexcept;

struct Component {
  std::string name;
  // Each may be empty (nothing to do). configure and start may throw with a message for the
  // user; stop and release must not throw (they run while unwinding a failure).
  std::function<void()> configure;
  std::function<void()> start;
  std::function<void()> stop;
  std::function<void()> release;
};

// Sees every transition of every component just before it runs; throwing from kConfigure or
// kStart makes that transition fail (a test injects failures so). Null: none.
using TransitionHook = std::function<void(std::string_view component, Transition transition)>;

class Lifecycle {
 public:
  explicit Lifecycle(TransitionHook hook = {}) : hook_(std::move(hook)) {}
  ~Lifecycle() { release(); }
  Lifecycle(const Lifecycle&) = delete;
  Lifecycle& operator=(const Lifecycle&) = delete;

  // Setup, before configure(): components run in the order they were added.
  void add(Component component) { components_.push_back(std::move(component)); }

  // Configures every component in order; when one throws, releases it and those configured
  // before it (reverse order) and rethrows. Once only.
  void configure();
  // Starts every component in order (after configure, when not started); when one throws, stops
  // it and those started before it (reverse order) and rethrows.
  void start();
  // Stops the started components in reverse order; idempotent.
  void stop() noexcept;
  // Stops, then releases the configured components in reverse order; idempotent.
  void release() noexcept;

  bool started() const noexcept { return started_ > 0; }
  std::vector<std::string> names() const;  // in list order

 private:
  void run(Component& component, Transition transition) noexcept;  // stop or release; logs what throws

  TransitionHook hook_;
  std::vector<Component> components_;
  std::size_t configured_ = 0;  // the first configured_ components are configured
  std::size_t started_ = 0;     // the first started_ components are started
};

}  // namespace doppel::gateway
