#include "gateway/lifecycle.h"

#include <exception>
#include <iostream>

namespace doppel::gateway {

std::string_view transition_name(Transition transition) noexcept {
  switch (transition) {
    case Transition::kConfigure: return "configure";
    case Transition::kStart: return "start";
    case Transition::kStop: return "stop";
    case Transition::kRelease: return "release";
  }
  return "?";
}

void Lifecycle::configure() {
  while (configured_ < components_.size()) {
    Component& component = components_[configured_];
    ++configured_;  // a failing component is released too: its release copes with what it left half done
    try {
      if (hook_) hook_(component.name, Transition::kConfigure);
      if (component.configure) component.configure();
    } catch (...) {
      release();
      throw;
    }
  }
}

void Lifecycle::start() {
  if (started_ > 0) return;
  while (started_ < configured_) {
    Component& component = components_[started_];
    ++started_;  // a failing component is stopped too: its stop copes with a part-done start
    try {
      if (hook_) hook_(component.name, Transition::kStart);
      if (component.start) component.start();
    } catch (...) {
      stop();
      throw;
    }
  }
}

void Lifecycle::stop() noexcept {
  while (started_ > 0) {
    --started_;
    run(components_[started_], Transition::kStop);
  }
}

void Lifecycle::release() noexcept {
  stop();
  while (configured_ > 0) {
    --configured_;
    run(components_[configured_], Transition::kRelease);
  }
}

void Lifecycle::run(Component& component, Transition transition) noexcept {
  const auto report = [&](const char* what) {
    std::cerr << "doppel: " << transition_name(transition) << " " << component.name << ": " << what << "\n" << std::flush;
  };
  const std::function<void()>& step = transition == Transition::kStop ? component.stop : component.release;
  try {
    if (hook_) hook_(component.name, transition);
  } catch (const std::exception& e) {
    report(e.what());
  }
  try {
    if (step) step();
  } catch (const std::exception& e) {
    report(e.what());
  }
}

std::vector<std::string> Lifecycle::names() const {
  std::vector<std::string> out;
  for (const Component& component : components_) out.push_back(component.name);
  return out;
}

}  // namespace doppel::gateway
