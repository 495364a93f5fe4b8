// BAM's identified MX models (dynamixel/bam_models.h) against the published files:
// Rhoban/bam bam/params/mx64/m*.json and mx106/m*.json at commit 1b5a1ce, kept to six significant
// digits (half a unit of the sixth: 5e-6 relative).

#include <gtest/gtest.h>

#include "dynamixel/bam_models.h"

namespace doppel::dynamixel {
namespace {

TEST(BamModels, CoverTheMx64AndMx106UnderBothFirmwares) {
  for (const char* model : {"MX-64", "MX-64(2.0)", "MX-106", "MX-106(2.0)"}) {
    for (int law = 1; law <= 6; ++law) {
      EXPECT_NE(find_bam_model(model, law), nullptr) << model << " M" << law;
    }
    EXPECT_EQ(find_bam_model(model, 0), nullptr) << model;
    EXPECT_EQ(find_bam_model(model, 7), nullptr) << model;
  }
  EXPECT_EQ(find_bam_model("MX-28", 1), nullptr);
  EXPECT_EQ(find_bam_model("XM430-W350", 6), nullptr);
  EXPECT_EQ(find_bam_model("mx64", 1), nullptr);  // registry names only
  EXPECT_EQ(find_bam_model("MX-64(2.0)", 3), find_bam_model("MX-64", 3));  // one motor, two firmwares
}

TEST(BamModels, CarryThePublishedNumbers) {
  // mx64/m2.json
  const BamModel& m2 = *find_bam_model("MX-64", 2);
  EXPECT_NEAR(m2.kt_nm_a, 1.6204381558934768, 5e-6 * 1.6204381558934768);
  EXPECT_NEAR(m2.resistance_ohm, 3.8944216519292354, 5e-6 * 3.8944216519292354);
  EXPECT_NEAR(m2.armature_kg_m2, 0.011923664899375061, 5e-6 * 0.011923664899375061);
  EXPECT_NEAR(m2.friction_base, 0.05611931763075957, 5e-6 * 0.05611931763075957);
  EXPECT_NEAR(m2.friction_stribeck, 0.08186411549068562, 5e-6 * 0.08186411549068562);
  EXPECT_NEAR(m2.dtheta_stribeck, 1.1202509555217797, 5e-6 * 1.1202509555217797);
  EXPECT_NEAR(m2.alpha, 2.9999999999758256, 5e-6 * 2.9999999999758256);
  EXPECT_NEAR(m2.friction_viscous, 0.019180846406029385, 5e-6 * 0.019180846406029385);
  EXPECT_EQ(m2.load_friction_motor, 0.0);  // M2 has no load term
  // mx106/m5.json
  const BamModel& m5 = *find_bam_model("MX-106", 5);
  EXPECT_NEAR(m5.kt_nm_a, 2.2087822411811935, 5e-6 * 2.2087822411811935);
  EXPECT_NEAR(m5.resistance_ohm, 2.0142427292798475, 5e-6 * 2.0142427292798475);
  EXPECT_NEAR(m5.load_friction_motor, 0.20763710226562626, 5e-6 * 0.20763710226562626);
  EXPECT_NEAR(m5.load_friction_external, 0.022684350817709906, 5e-6 * 0.022684350817709906);
  EXPECT_NEAR(m5.load_friction_motor_stribeck, 0.19519320110890795, 5e-6 * 0.19519320110890795);
  EXPECT_NEAR(m5.load_friction_external_stribeck, 0.08490162305974122, 5e-6 * 0.08490162305974122);
  EXPECT_EQ(m5.load_friction_motor_quad, 0.0);  // the quadratic term is M6's
  // mx64/m3.json: the undirected load coefficient.
  EXPECT_NEAR(find_bam_model("MX-64", 3)->load_friction_base, 0.07580074806755707, 1e-7);
}

}  // namespace
}  // namespace doppel::dynamixel
