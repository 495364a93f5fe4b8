// doppel-servo-check: Doppel's servo model against Rhoban's BAM measurements (docs/fidelity.md).
//   doppel-servo-check log FILE... [--servo MX-64] [--friction all|default|m1..m6] [--engine ode|bullet]
//   doppel-servo-check speed velocity_mx64.json [--servo MX-64]
//   doppel-servo-check duty pwm_mx64.json [--servo MX-64]
// The files are BAM's (not shipped with Doppel); errors name the file and what is wrong.

#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "body/motor_params.h"
#include "body/servo_check.h"
#include "physics/engines.h"

namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(path + ": cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// "default" -> 0, "m1".."m6" -> 1..6; "all" -> every one.
std::vector<int> friction_choices(const std::string& friction) {
  if (friction == "all") return {0, 1, 2, 3, 4, 5, 6};
  if (friction == "default") return {0};
  if (friction.size() == 2 && (friction[0] == 'm' || friction[0] == 'M') && friction[1] >= '1' && friction[1] <= '6') {
    return {friction[1] - '0'};
  }
  throw std::invalid_argument("--friction: '" + friction + "' is none of all, default, m1 .. m6");
}

std::string label(int bam_model) { return bam_model == 0 ? "default" : "BAM M" + std::to_string(bam_model); }

int run_logs(const std::vector<std::string>& files, const std::string& servo, const std::string& friction,
             const std::string& engine, bool armature) {
  std::vector<int> choices = friction_choices(friction);
  if (friction == "all" && !doppel::body::find_motor_params(servo, 1)) choices = {0};  // no BAM identification
  const doppel::physics::Engine chosen = doppel::physics::engine_from_name(engine);
  std::vector<double> mae_sum(choices.size(), 0.0);
  std::vector<double> rmse_sum(choices.size(), 0.0);
  std::printf("%-40s %-9s %4s %6s", "log", "traj", "kp", "mass");
  for (int c : choices) std::printf(" | %-9s MAE  RMSE", label(c).c_str());
  std::printf("   (mrad)\n");
  for (const std::string& file : files) {
    const doppel::body::PendulumLog log = doppel::body::parse_bam_log(read_file(file), file);
    std::printf("%-40s %-9s %4.0f %6.3f", file.substr(file.size() > 40 ? file.size() - 40 : 0).c_str(),
                log.trajectory.substr(0, 9).c_str(), log.kp, log.mass_kg);
    for (std::size_t i = 0; i < choices.size(); ++i) {
      doppel::body::ReplayOptions options;
      options.servo = servo;
      options.bam_model = choices[i];
      options.armature = armature;
      const doppel::body::ReplayResult r =
          doppel::body::replay_bam_log(log, options, doppel::physics::make_backend(chosen));
      mae_sum[i] += r.mae_rad;
      rmse_sum[i] += r.rmse_rad;
      std::printf(" | %9s %5.1f %5.1f", "", 1e3 * r.mae_rad, 1e3 * r.rmse_rad);
    }
    std::printf("\n");
  }
  std::printf("%-40s %-9s %4s %6s", "mean over logs", "", "", "");
  for (std::size_t i = 0; i < choices.size(); ++i) {
    std::printf(" | %9s %5.1f %5.1f", "", 1e3 * mae_sum[i] / static_cast<double>(files.size()),
                1e3 * rmse_sum[i] / static_cast<double>(files.size()));
  }
  std::printf("\n");
  return 0;
}

int run_speed(const std::string& file, const std::string& servo) {
  const auto points = doppel::body::parse_speed_table(read_file(file), file);
  std::vector<int> choices{0};
  if (doppel::body::find_motor_params(servo, 1)) choices = {0, 1, 2, 3, 4, 5, 6};
  std::printf("%6s %9s", "volts", "measured");
  for (int c : choices) std::printf(" %9s", label(c).c_str());
  std::printf("   (rad/s)\n");
  std::vector<double> abs_sum(choices.size(), 0.0);
  std::vector<double> sq_sum(choices.size(), 0.0);
  for (const auto& p : points) {
    std::printf("%6.1f %9.3f", p.volts, p.measured_rad_s);
    for (std::size_t i = 0; i < choices.size(); ++i) {
      const double w = doppel::body::doppel_no_load_speed_rad_s(servo, choices[i], p.volts);
      abs_sum[i] += std::abs(w - p.measured_rad_s);
      sq_sum[i] += (w - p.measured_rad_s) * (w - p.measured_rad_s);
      std::printf(" %9.3f", w);
    }
    std::printf("\n");
  }
  const double n = static_cast<double>(points.size());
  std::printf("%16s", "MAE");
  for (std::size_t i = 0; i < choices.size(); ++i) std::printf(" %9.3f", abs_sum[i] / n);
  std::printf("\n%16s", "RMSE");
  for (std::size_t i = 0; i < choices.size(); ++i) std::printf(" %9.3f", std::sqrt(sq_sum[i] / n));
  std::printf("\n");
  return 0;
}

int run_duty(const std::string& file, const std::string& servo) {
  const auto points = doppel::body::parse_duty_table(read_file(file), file);
  std::printf("%4s %9s %9s %9s\n", "P", "error deg", "measured", "doppel");
  double abs_sum = 0.0;
  double sq_sum = 0.0;
  for (const auto& p : points) {
    const double duty = doppel::body::doppel_duty(servo, p.kp, p.error_rad);
    abs_sum += std::abs(duty - p.measured_duty);
    sq_sum += (duty - p.measured_duty) * (duty - p.measured_duty);
    std::printf("%4.0f %9.2f %9.4f %9.4f\n", p.kp, p.error_rad * 180.0 / M_PI, p.measured_duty, duty);
  }
  const double n = static_cast<double>(points.size());
  std::printf("duty MAE %.4f, RMSE %.4f over %zu readings\n", abs_sum / n, std::sqrt(sq_sum / n), points.size());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Doppel's servo model against Rhoban's BAM measurements (docs/fidelity.md)"};
  app.require_subcommand(1);
  std::string servo = "MX-64";
  app.add_option("--servo", servo, "registry servo model (MX-64, MX-106, ...)");

  CLI::App* log = app.add_subcommand("log", "replay BAM pendulum logs (raw or processed JSON) and report the position error");
  std::vector<std::string> files;
  std::string friction = "all";
  std::string engine = "ode";
  bool no_armature = false;
  log->add_option("files", files, "BAM log files")->required()->check(CLI::ExistingFile);
  log->add_option("--friction", friction, "all, default (the registry's), m1 .. m6 (BAM's identification)");
  log->add_option("--engine", engine, "ode or bullet");
  log->add_flag("--no-armature", no_armature, "do not add BAM's armature to the pendulum");

  CLI::App* speed = app.add_subcommand("speed", "no-load speed per motor voltage (atomic/data/velocity_*.json)");
  std::string speed_file;
  speed->add_option("file", speed_file)->required()->check(CLI::ExistingFile);

  CLI::App* duty = app.add_subcommand("duty", "PWM duty per position error and P gain (atomic/data/pwm_*.json)");
  std::string duty_file;
  duty->add_option("file", duty_file)->required()->check(CLI::ExistingFile);

  CLI11_PARSE(app, argc, argv);
  try {
    if (log->parsed()) return run_logs(files, servo, friction, engine, !no_armature);
    if (speed->parsed()) return run_speed(speed_file, servo);
    return run_duty(duty_file, servo);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "doppel-servo-check: %s\n", e.what());
    return 1;
  }
}
