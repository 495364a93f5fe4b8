// The BAM check (body/servo_check.h): BAM's log formats read, bad files named, and a replay that
// agrees with a pendulum log generated here from BAM's published equations (docs/theory of
// Rhoban/bam: pendulum tau_m + tau_e + tau_f = J q'', DC motor tau_m = kt (V - kt q') / R, MX
// firmware duty = 0.158 P error, friction = stopping torque clipped to the M1 budget) with the
// MX-64's published M1 parameters (bam/params/mx64/m1.json). No BAM file is shipped: the synthetic
// log stands in for the measured ones, which the tool reads when the user has them.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "body/servo_check.h"
#include "physics/engines.h"

namespace doppel::body {
namespace {

constexpr double kKt = 1.6224667906987444;
constexpr double kR = 3.949433673232461;
constexpr double kArmature = 0.011951238325312509;
constexpr double kCoulomb = 0.09038677246291783;
constexpr double kViscous = 0.011691602145974832;

struct Bench {
  double mass = 0.6;
  double arm_mass = 0.1;
  double length = 0.15;
  double kp = 16.0;
  double vin = 15.0;
};

double sign(double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); }

// A processed BAM log (dt 5 ms) of the bench following goal(t) with torque on until `release_s`,
// then limp, integrated at 1 ms with BAM's simulator step.
std::string synthetic_log(const Bench& b, double duration_s, double release_s, double position_shift = 0.0) {
  const double g = 9.80665;
  const double dt = 0.001;
  const double inertia = b.mass * b.length * b.length + b.arm_mass * b.length * b.length / 3.0 + kArmature;
  double q = 0.0;
  double dq = 0.0;
  std::ostringstream out;
  out.precision(17);
  out << R"({"mass": )" << b.mass << R"(, "arm_mass": )" << b.arm_mass << R"(, "length": )" << b.length
      << R"(, "kp": )" << b.kp << R"(, "vin": )" << b.vin
      << R"(, "motor": "mx64", "trajectory": "synthetic", "dt": 0.005, "entries": [)";
  const int steps = static_cast<int>(std::lround(duration_s / dt));
  for (int k = 0; k <= steps; ++k) {
    const double t = k * dt;
    const double goal = 0.8 * std::sin(std::numbers::pi * t);
    const bool torque = t < release_s;
    if (k % 5 == 0) {
      out << (k == 0 ? "" : ", ") << R"({"position": )" << (k == 0 ? q : q + position_shift)
          << R"(, "goal_position": )" << goal << R"(, "torque_enable": )" << (torque ? "true" : "false") << "}";
    }
    const double bias = -(b.mass + b.arm_mass / 2.0) * g * b.length * std::sin(q);
    const double duty = std::clamp(0.158 * b.kp * (goal - q), -1.0, 1.0);
    const double motor = torque ? kKt * (b.vin * duty) / kR - kKt * kKt * dq / kR : 0.0;
    const double budget = kCoulomb + kViscous * std::abs(dq);
    double net = motor + bias;
    const double stop = inertia / dt * dq + net;
    net += -sign(stop) * std::min(std::abs(stop), budget);
    const double acc = net / inertia;
    dq += acc * dt;
    q += dq * dt + 0.5 * acc * dt * dt;
  }
  out << "]}";
  return out.str();
}

class ServoCheckTest : public ::testing::TestWithParam<std::string> {};

TEST_P(ServoCheckTest, ReplayWithBamsModelFollowsALogOfBamsEquations) {
  const PendulumLog log = parse_bam_log(synthetic_log(Bench{}, 5.0, 4.0), "synthetic.json");
  ReplayOptions options;
  options.bam_model = 1;

  const ReplayResult r = replay_bam_log(log, options, physics::make_backend(physics::engine_from_name(GetParam())));

  ASSERT_EQ(r.samples, log.samples.size());
  // The arm swung 0.8 rad each way and then dropped; the two integrations of the same equations
  // agree within 5 mrad (3 encoder ticks of 1.53 mrad).
  EXPECT_LT(r.mae_rad, 0.005);
  EXPECT_LT(r.max_error_rad, 0.03);
  EXPECT_GE(r.rmse_rad, r.mae_rad);
}

TEST(ServoCheck, AGainBeyondTheServosRegisterIsAnError) {
  Bench bench;
  bench.kp = 800;  // an X servo's Position P Gain, not an MX's
  const PendulumLog log = parse_bam_log(synthetic_log(bench, 0.1, 1.0), "x-gain.json");
  EXPECT_THROW((void)replay_bam_log(log, ReplayOptions{}, physics::make_backend(physics::Engine::kOde)),
               std::invalid_argument);
}

TEST_P(ServoCheckTest, ErrorIsMeasuredAgainstTheLoggedPositions) {
  // The same motion logged 50 mrad off after its first sample: the error shows it.
  const PendulumLog log = parse_bam_log(synthetic_log(Bench{}, 3.0, 10.0, 0.05), "shifted.json");
  ReplayOptions options;
  options.bam_model = 1;

  const ReplayResult r = replay_bam_log(log, options, physics::make_backend(physics::engine_from_name(GetParam())));

  EXPECT_NEAR(r.mae_rad, 0.05, 0.006);
}

INSTANTIATE_TEST_SUITE_P(Engines, ServoCheckTest, ::testing::ValuesIn(physics::engine_names()),
                         [](const ::testing::TestParamInfo<std::string>& param) { return param.param; });

TEST(ServoCheck, ReadsBamsRawLogFormat) {
  // bam/dynamixel/record.py: "arm-mass", timestamps, torque_enable as a boolean.
  const PendulumLog log = parse_bam_log(
      R"({"mass": 0.5, "arm-mass": 0.05, "length": 0.15, "kp": 32, "vin": 15.0, "motor": "mx64",
          "trajectory": "lift_and_drop", "entries": [
          {"position": 0.1, "speed": 0, "load": 0, "timestamp": 0.002, "goal_position": 0.0, "torque_enable": true},
          {"position": 0.2, "speed": 0, "load": 0, "timestamp": 0.007, "goal_position": 0.5, "torque_enable": false}]})",
      "raw.json");
  EXPECT_DOUBLE_EQ(log.arm_mass_kg, 0.05);
  EXPECT_DOUBLE_EQ(log.kp, 32.0);
  EXPECT_EQ(log.trajectory, "lift_and_drop");
  ASSERT_EQ(log.samples.size(), 2u);
  EXPECT_DOUBLE_EQ(log.samples[1].time_s, 0.007);
  EXPECT_DOUBLE_EQ(log.samples[1].goal_position_rad, 0.5);
  EXPECT_FALSE(log.samples[1].torque_enable);
}

TEST(ServoCheck, ReadsBamsProcessedLogFormat) {
  // bam/process.py: resampled at dt, torque_enable interpolated then thresholded (a number here).
  const PendulumLog log = parse_bam_log(
      R"({"mass": 0.5, "arm_mass": 0.0, "length": 0.1, "kp": 8, "dt": 0.005, "entries": [
          {"position": 0.0, "goal_position": 0.0, "torque_enable": 1.0},
          {"position": 0.0, "goal_position": 0.1, "torque_enable": 0.0},
          {"position": 0.0, "goal_position": 0.1, "torque_enable": 0.0}]})",
      "processed.json");
  EXPECT_DOUBLE_EQ(log.vin_v, 15.0);  // BAM's MX default when the log has none
  ASSERT_EQ(log.samples.size(), 3u);
  EXPECT_DOUBLE_EQ(log.samples[2].time_s, 0.01);
  EXPECT_TRUE(log.samples[0].torque_enable);
  EXPECT_FALSE(log.samples[1].torque_enable);
}

void expect_rejected(const std::string& text, const std::string& words) {
  try {
    (void)parse_bam_log(text, "bad.json");
    ADD_FAILURE() << "accepted: " << text;
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bad.json"), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
  }
}

TEST(ServoCheck, BadLogsAreNamedWithWhatIsWrong) {
  const std::string head = R"({"mass": 0.5, "length": 0.15, "kp": 32, )";
  const std::string e0 = R"({"position": 0, "goal_position": 0, "torque_enable": true, "timestamp": 0.0})";
  expect_rejected("{\"mass\": 0.5, \x01", "not JSON");
  expect_rejected("[1, 2]", "not a JSON object");
  expect_rejected(R"({"length": 0.15, "kp": 32, "entries": []})", "'mass' is missing");
  expect_rejected(head + R"("entries": 3})", "'entries'");
  expect_rejected(head + R"("entries": [)" + e0 + "]}", "at least two");
  expect_rejected(head + R"("entries": [)" + e0 + ", " + e0 + "]}", "does not increase");
  expect_rejected(head + R"("entries": [)" + e0 +
                      R"(, {"position": "up", "goal_position": 0, "torque_enable": true, "timestamp": 1}]})",
                  "entries[1]: 'position' is not a number");
  expect_rejected(head + R"("entries": [)" + e0 + R"(, {"position": 0, "torque_enable": true, "timestamp": 1}]})",
                  "'goal_position' is missing");
  expect_rejected(R"({"mass": 0.5, "length": 0.15, "kp": 20000, "entries": []})", "'kp'");
  expect_rejected(R"({"mass": 0.5, "length": -1, "kp": 3, "entries": []})", "'length'");
  expect_rejected(head + R"("entries": [{"position": 0, "goal_position": 0, "torque_enable": true}, {}]})", "'dt'");
}

TEST(ServoCheck, SteadyStateTables) {
  // atomic/data/velocity_mx64.json and pwm_mx64.json formats (two of their entries each).
  const auto speeds = parse_speed_table(R"({"2.0": 1.1207263636292493, "1.0": 0.5319845372387404})", "v.json");
  ASSERT_EQ(speeds.size(), 2u);
  EXPECT_DOUBLE_EQ(speeds[0].volts, 1.0);
  EXPECT_DOUBLE_EQ(speeds[1].measured_rad_s, 1.1207263636292493);
  EXPECT_THROW((void)parse_speed_table(R"({"abc": 1.0})", "v.json"), std::invalid_argument);
  EXPECT_THROW((void)parse_speed_table(R"({})", "v.json"), std::invalid_argument);

  const auto duties = parse_duty_table(
      R"({"pwm_period": 42.6, "samples": [{"target": 157.24, "position": 165.2, "voltage": 15.0, "period": 4.5, "kp": 5}]})",
      "p.json");
  ASSERT_EQ(duties.size(), 1u);
  EXPECT_NEAR(duties[0].error_rad, (165.2 - 157.24) * std::numbers::pi / 180.0, 1e-12);
  EXPECT_NEAR(duties[0].measured_duty, 4.5 / 42.6, 1e-12);
  EXPECT_THROW((void)parse_duty_table(R"({"pwm_period": 0, "samples": []})", "p.json"), std::invalid_argument);

  // Doppel's answers: the MX firmware's duty 0.158 P error (Rhoban's oscilloscope figure the
  // registry carries) and BAM M1's no-load line kt (V - kt w) / R = Kc + Kv w.
  EXPECT_NEAR(doppel_duty("MX-64", 32.0, 0.1), 0.158 * 32.0 * 0.1, 1e-9);
  EXPECT_NEAR(doppel_duty("MX-64", 32.0, 1.0), 1.0, 1e-12);  // saturated
  const double w = (kKt * 12.0 / kR - kCoulomb) / (kKt * kKt / kR + kViscous);
  EXPECT_NEAR(doppel_no_load_speed_rad_s("MX-64", 1, 12.0), w, 1e-5 * w);  // BAM's numbers to 6 digits
}

}  // namespace
}  // namespace doppel::body
