#include <spawn.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analyzer/report.h"

extern char** environ;

namespace doppel::analyzer {

namespace {

namespace fs = std::filesystem;

// The gnuplot executable on PATH, or "".
std::string find_gnuplot() {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return "";
  std::stringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const std::string candidate = dir + "/gnuplot";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return "";
}

// A temporary directory removed with everything in it when this goes out of scope.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "doppel-bus-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      throw std::runtime_error("cannot create a temporary directory for gnuplot: " + std::string(std::strerror(errno)));
    }
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

// gnuplot strings are in double quotes; the kind names hold no quotes, but be safe.
std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out.push_back('\\');
    out.push_back(c);
  }
  return out + "\"";
}

void run_gnuplot(const std::string& gnuplot, const fs::path& script, const fs::path& log) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
  posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
  std::string arg0 = gnuplot;
  std::string arg1 = script.string();
  char* argv[] = {arg0.data(), arg1.data(), nullptr};
  pid_t pid = 0;
  const int rc = ::posix_spawn(&pid, gnuplot.c_str(), &actions, nullptr, argv, environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw PlotError("cannot start " + gnuplot + ": " + std::strerror(rc));
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::ifstream in(log);
    std::stringstream text;
    text << in.rdbuf();
    throw PlotError("gnuplot failed on " + script.filename().string() + ": " + text.str());
  }
}

}  // namespace

std::vector<std::string> write_plots(const Report& report, const std::string& directory, const std::string& prefix) {
  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty()) {
    throw PlotError("gnuplot not found on PATH: install gnuplot-nox (apt-get install gnuplot-nox) to draw --png plots");
  }
  std::error_code error;
  fs::create_directories(directory, error);
  if (error || !fs::is_directory(directory)) {
    throw std::runtime_error("cannot create the plot directory " + directory + ": " + error.message());
  }
  const Analysis& a = report.analysis;
  TempDir temp;
  std::ostringstream script;
  script << "set terminal pngcairo size 1000,560 font 'sans,10'\nset grid ytics\nset key outside right top\n";
  std::vector<std::string> written;
  auto output = [&](const std::string& name) {
    const std::string file = (fs::absolute(directory) / (prefix + name)).string();
    written.push_back(file);
    script << "set output " << quoted(file) << "\n";
  };
  const std::string title = a.robot_name.empty() ? "robot " + std::to_string(a.robot) : a.robot_name;

  if (a.cycle.found && a.cycle.starts_ns.size() >= 2) {
    // Period over time.
    std::ostringstream data;
    std::vector<double> periods_us;
    for (std::size_t k = 1; k < a.cycle.starts_ns.size(); ++k) {
      const double t_s = static_cast<double>(a.cycle.starts_ns[k] - a.cycle.starts_ns.front()) / 1e9;
      const double period_us = static_cast<double>(a.cycle.starts_ns[k] - a.cycle.starts_ns[k - 1]) / 1e3;
      periods_us.push_back(period_us);
      data << t_s << " " << period_us << "\n";
    }
    write_file(temp.path() / "period.dat", data.str());
    output("cycle_period.png");
    script << "set title " << quoted(title + ": control cycle period (opener " + a.cycle.opener_kind + ")") << "\n"
           << "set xlabel 'time since the first cycle, s'\nset ylabel 'period, us'\nunset key\n"
           << "plot " << quoted((temp.path() / "period.dat").string()) << " using 1:2 with lines lw 1\n";

    // Histogram, up to p99 + (p99 - p50) so that a few outliers do not squash it.
    const double lo = a.cycle.period.min_ns / 1e3;
    const double hi = std::max(lo + 1.0, std::min(a.cycle.period.max_ns, 2 * a.cycle.period.p99_ns - a.cycle.period.p50_ns) / 1e3);
    constexpr int kBins = 60;
    std::vector<uint64_t> bins(kBins, 0);
    uint64_t beyond = 0;
    for (double p : periods_us) {
      if (p > hi) {
        ++beyond;
        continue;
      }
      const int bin = std::clamp(static_cast<int>((p - lo) / (hi - lo) * kBins), 0, kBins - 1);
      ++bins[static_cast<std::size_t>(bin)];
    }
    std::ostringstream hist;
    const double width = (hi - lo) / kBins;
    for (int i = 0; i < kBins; ++i) hist << lo + (i + 0.5) * width << " " << bins[static_cast<std::size_t>(i)] << "\n";
    write_file(temp.path() / "histogram.dat", hist.str());
    output("period_histogram.png");
    std::string note = "histogram of the cycle period";
    if (beyond > 0) note += " (" + std::to_string(beyond) + " periods above " + std::to_string(static_cast<int>(hi)) + " us not shown)";
    script << "set title " << quoted(title + ": " + note) << "\n"
           << "set xlabel 'period, us'\nset ylabel 'cycles'\nset style fill solid 0.6\nset boxwidth " << width * 0.9 << "\n"
           << "plot " << quoted((temp.path() / "histogram.dat").string()) << " using 1:2 with boxes\n";
  }

  if (!a.kinds.empty()) {
    std::ostringstream data;
    data << "kind \"host write\" \"return delay\" \"status wire\" \"status gaps\" adapter \"Doppel late\"\n";
    for (const KindStats& k : a.kinds) {
      data << quoted(k.kind + " (" + std::to_string(k.count) + ")") << " " << k.host_write.mean_ns / 1e3 << " "
           << k.return_delay.mean_ns / 1e3 << " " << k.status_wire.mean_ns / 1e3 << " " << k.status_gaps.mean_ns / 1e3
           << " " << k.adapter.mean_ns / 1e3 << " " << k.lateness.mean_ns / 1e3 << "\n";
    }
    write_file(temp.path() / "split.dat", data.str());
    output("time_split.png");
    script << "set title " << quoted(title + ": where the time of each transaction kind goes (mean)") << "\n"
           << "set xlabel ''\nset ylabel 'us'\nset key outside right top\nset style data histograms\n"
           << "set style histogram rowstacked\nset style fill solid 0.8 border -1\nset boxwidth 0.6\n"
           << "set xtics rotate by -20\nset yrange [0:*]\n"
           << "plot for [i=2:7] " << quoted((temp.path() / "split.dat").string()) << " using i:xtic(1) title columnheader(i)\n"
           << "set xtics norotate\nset yrange [*:*]\n";
  }

  bool any_what_if = false;
  for (const WhatIf& w : report.what_ifs) any_what_if = any_what_if || w.cycles > 0;
  if (any_what_if) {
    std::ostringstream data;
    if (a.cycle.found) data << quoted("measured") << " " << a.cycle.rate_hz << "\n";
    for (const WhatIf& w : report.what_ifs) {
      if (w.cycles > 0) data << quoted(scenario_label(w)) << " " << w.rate_hz << "\n";
    }
    write_file(temp.path() / "what_if.dat", data.str());
    output("what_if.png");
    script << "set title " << quoted(title + ": achievable cycle rate (the bus alone)") << "\n"
           << "set style data boxes\nset style fill solid 0.7 border -1\nset boxwidth 0.6\nunset key\n"
           << "set xlabel ''\nset ylabel 'cycles per second, Hz'\nset xtics rotate by -20\nset yrange [0:*]\n"
           << "plot " << quoted((temp.path() / "what_if.dat").string())
           << " using 0:2:xtic(1) with boxes, '' using 0:2:(sprintf('%.0f', $2)) with labels offset 0,0.7\n";
  }

  if (written.empty()) return written;
  write_file(temp.path() / "plots.gp", script.str());
  run_gnuplot(gnuplot, temp.path() / "plots.gp", temp.path() / "gnuplot.log");
  return written;
}

}  // namespace doppel::analyzer
