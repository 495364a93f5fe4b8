#include "teamcomm/link_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace doppel::teamcomm {
namespace {

TEST(LinkModel, NoLossNoDelayByDefault) {
  LinkModel sut(LinkModelConfig{}, 1);
  for (int i = 0; i < 1000; ++i) {
    const LinkDecision d = sut.next();
    EXPECT_FALSE(d.drop);
    EXPECT_EQ(d.delay_ns, 0);
  }
}

TEST(LinkModel, LossOfOneDropsEverything) {
  LinkModelConfig config;
  config.loss_probability = 1.0;
  LinkModel sut(config, 7);
  for (int i = 0; i < 1000; ++i) EXPECT_TRUE(sut.next().drop);
}

// Binomial: n draws at p give a dropped count with mean n p and standard deviation sqrt(n p (1 - p)).
TEST(LinkModel, BernoulliLossShareWithinFourSigma) {
  constexpr int kN = 10000;
  constexpr double kP = 0.2;
  LinkModelConfig config;
  config.loss_probability = kP;
  LinkModel sut(config, 42);
  int dropped = 0;
  for (int i = 0; i < kN; ++i) dropped += sut.next().drop ? 1 : 0;
  const double sigma = std::sqrt(kN * kP * (1 - kP));
  EXPECT_NEAR(dropped, kN * kP, 4 * sigma);
}

TEST(LinkModel, UniformJitterStaysWithinDelayAndDelayPlusJitter) {
  LinkModelConfig config;
  config.delay_ns = 20'000'000;
  config.jitter_ns = 5'000'000;
  LinkModel sut(config, 3);
  double sum = 0;
  constexpr int kN = 10000;
  for (int i = 0; i < kN; ++i) {
    const LinkDecision d = sut.next();
    ASSERT_GE(d.delay_ns, config.delay_ns);
    ASSERT_LE(d.delay_ns, config.delay_ns + config.jitter_ns);
    sum += static_cast<double>(d.delay_ns - config.delay_ns);
  }
  // U[0, J]: mean J/2, standard deviation J/sqrt(12); the mean of kN within 4 standard errors.
  const double j = static_cast<double>(config.jitter_ns);
  EXPECT_NEAR(sum / kN, j / 2, 4 * j / std::sqrt(12.0) / std::sqrt(kN));
}

TEST(LinkModel, HalfNormalJitterNeverEarlierAndHasTheHalfNormalMean) {
  LinkModelConfig config;
  config.delay_ns = 10'000'000;
  config.jitter_ns = 2'000'000;
  config.jitter = Jitter::kHalfNormal;
  LinkModel sut(config, 5);
  double sum = 0;
  constexpr int kN = 20000;
  for (int i = 0; i < kN; ++i) {
    const LinkDecision d = sut.next();
    ASSERT_GE(d.delay_ns, config.delay_ns);
    sum += static_cast<double>(d.delay_ns - config.delay_ns);
  }
  // |N(0, s)|: mean s sqrt(2/pi), variance s^2 (1 - 2/pi).
  const double s = static_cast<double>(config.jitter_ns);
  const double se = s * std::sqrt(1 - 2 / std::numbers::pi) / std::sqrt(kN);
  EXPECT_NEAR(sum / kN, s * std::sqrt(2 / std::numbers::pi), 4 * se);
}

// Gilbert-Elliott with total loss in the bad state: losses come in runs whose length is geometric
// with mean 1 / p_bad_to_good, and the long-run loss share is p_gb / (p_gb + p_bg).
TEST(LinkModel, BurstLossHasGeometricBurstsAndTheStationaryShare) {
  LinkModelConfig config;
  config.burst = true;
  config.p_good_to_bad = 0.05;
  config.p_bad_to_good = 0.25;
  config.loss_in_bad = 1.0;
  LinkModel sut(config, 11);
  constexpr int kN = 400000;
  int dropped = 0, bursts = 0;
  bool previous = false;
  for (int i = 0; i < kN; ++i) {
    const bool drop = sut.next().drop;
    dropped += drop ? 1 : 0;
    if (drop && !previous) ++bursts;
    previous = drop;
  }
  // About kN * 0.05 * 5/6 = 16,700 bursts; a geometric run length has sd sqrt(1 - p) / p = 3.46.
  const double mean_burst = static_cast<double>(dropped) / bursts;
  EXPECT_NEAR(mean_burst, 1 / config.p_bad_to_good, 4 * std::sqrt(1 - 0.25) / 0.25 / std::sqrt(bursts));
  const double share = static_cast<double>(dropped) / kN;
  EXPECT_NEAR(share, 0.05 / 0.30, 0.01);
  // Independent losses at the same share would give runs of mean 1 / (1 - 1/6) = 1.2.
  EXPECT_GT(mean_burst, 3.0);
}

TEST(LinkModel, SameSeedSameDecisionsOtherSeedOtherDecisions) {
  LinkModelConfig config;
  config.loss_probability = 0.5;
  config.jitter_ns = 1'000'000;
  LinkModel a(config, 99), b(config, 99), c(config, 100);
  int differ = 0;
  for (int i = 0; i < 1000; ++i) {
    const LinkDecision da = a.next(), db = b.next(), dc = c.next();
    ASSERT_EQ(da.drop, db.drop);
    ASSERT_EQ(da.delay_ns, db.delay_ns);
    differ += (da.drop != dc.drop || da.delay_ns != dc.delay_ns) ? 1 : 0;
  }
  EXPECT_GT(differ, 100);
}

TEST(LinkModel, RejectsValuesOutsideTheirRange) {
  LinkModelConfig config;
  config.loss_probability = 1.5;
  EXPECT_THROW(LinkModel(config, 1), std::invalid_argument);
  config = {};
  config.delay_ns = -1;
  EXPECT_THROW(LinkModel(config, 1), std::invalid_argument);
  config = {};
  config.p_bad_to_good = -0.1;
  EXPECT_THROW(LinkModel(config, 1), std::invalid_argument);
}

}  // namespace
}  // namespace doppel::teamcomm
