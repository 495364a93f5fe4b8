#pragma once
// What a WiFi link does to one relayed team message: lose it (independently with a fixed
// probability, or in bursts by a Gilbert-Elliott two-state chain) or hold it back (a fixed delay
// plus jitter). A pure model: no clock and no socket inside, so a test can count its decisions;
// the hub asks it once per (message, receiver) pair. Seeded, so the same seed gives the same
// decisions for the same sequence of messages on a link.
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>

namespace doppel::teamcomm {

enum class Jitter : std::uint8_t {
  kUniform,     // delay + U[0, jitter]
  kHalfNormal,  // delay + |N(0, jitter)|: never earlier than the fixed delay
};

struct LinkModelConfig {
  double loss_probability = 0.0;  // Bernoulli loss per relay (in the good state of the burst model), [0, 1]
  std::int64_t delay_ns = 0;      // fixed delay added to every relay, >= 0
  std::int64_t jitter_ns = 0;     // jitter scale (uniform width or normal sigma), >= 0
  Jitter jitter = Jitter::kUniform;
  bool burst = false;             // Gilbert-Elliott: a good and a bad state, switched per relay
  double p_good_to_bad = 0.0;     // per relay, probability to enter the bad state, [0, 1]
  double p_bad_to_good = 1.0;     // per relay, probability to leave the bad state, [0, 1]
  double loss_in_bad = 1.0;       // loss probability while in the bad state, [0, 1]
};

// Throws std::invalid_argument naming the field when a value is outside its range.
void validate(const LinkModelConfig& config);

struct LinkDecision {
  bool drop = false;         // the message is lost on this link
  std::int64_t delay_ns = 0; // when not dropped: how long after arrival it is delivered, >= config.delay_ns
};

class LinkModel {
 public:
  // Throws std::invalid_argument on a bad config (see validate()).
  LinkModel(const LinkModelConfig& config, std::uint64_t seed);
  // One relay's fate. Draws from the link's own generator; no allocation.
  LinkDecision next() noexcept;
  bool in_bad_state() const noexcept { return bad_; }

 private:
  LinkModelConfig config_;
  std::mt19937_64 rng_;
  bool bad_ = false;
};

}  // namespace doppel::teamcomm
