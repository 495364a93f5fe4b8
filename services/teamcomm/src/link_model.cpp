#include "teamcomm/link_model.h"

#include <cmath>

namespace doppel::teamcomm {
namespace {

void check_probability(double p, const char* field) {
  if (!(p >= 0.0 && p <= 1.0)) {
    throw std::invalid_argument(std::string("link model: ") + field + " must be within [0, 1], got " +
                                std::to_string(p));
  }
}

}  // namespace

void validate(const LinkModelConfig& config) {
  check_probability(config.loss_probability, "loss probability");
  check_probability(config.p_good_to_bad, "burst good->bad probability");
  check_probability(config.p_bad_to_good, "burst bad->good probability");
  check_probability(config.loss_in_bad, "burst loss in the bad state");
  if (config.delay_ns < 0) throw std::invalid_argument("link model: delay must not be negative");
  if (config.jitter_ns < 0) throw std::invalid_argument("link model: jitter must not be negative");
}

LinkModel::LinkModel(const LinkModelConfig& config, std::uint64_t seed) : config_(config), rng_(seed) {
  validate(config_);
}

LinkDecision LinkModel::next() noexcept {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double loss = config_.loss_probability;
  if (config_.burst) {
    // The state moves first, then this relay is lost with the new state's probability.
    const double u = unit(rng_);
    bad_ = bad_ ? !(u < config_.p_bad_to_good) : (u < config_.p_good_to_bad);
    if (bad_) loss = config_.loss_in_bad;
  }
  LinkDecision decision;
  // A probability of 0 never drops, 1 always drops: unit() is in [0, 1).
  decision.drop = loss > 0.0 && unit(rng_) < loss;
  if (decision.drop) return decision;
  decision.delay_ns = config_.delay_ns;
  if (config_.jitter_ns > 0) {
    const double j = static_cast<double>(config_.jitter_ns);
    if (config_.jitter == Jitter::kUniform) {
      decision.delay_ns += static_cast<std::int64_t>(unit(rng_) * j);
    } else {
      std::normal_distribution<double> normal(0.0, j);
      decision.delay_ns += static_cast<std::int64_t>(std::fabs(normal(rng_)));
    }
  }
  return decision;
}

}  // namespace doppel::teamcomm
