// End to end: a vision loop (lockstep_vision.c, written from the V4L2 specification) reads the
// DARwIn-OP's head camera (HEAD_CAMERA: 320x240 YUYV at 30 fps, data/robots/darwin-op.textproto) over
// /dev/video0 under doppel-run --lockstep against doppel --lockstep (issue 24, item 2). Two runs
// must give the same frames in the same order at the same simulation times (the client's hash of
// sequence, timestamp and pixels, and doppel's run hashes); frame k after STREAMON at simulation
// time 0 is the camera's frame k, due at k / 30 s and taken at the first 1 ms step at or after it
// (docs/lockstep.md, "Cameras"), stamped with that time on the program's CLOCK_MONOTONIC (1000 s +
// simulation time) and got by the program at exactly that time. doppel starts RouDi, so the
// executable holds the `roudi` lock.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "doppel_process.h"

namespace doppel::testing {
namespace {

const std::string kDoppelRun = DOPPEL_RUN;
const std::string kVision = LOCKSTEP_VISION;
constexpr int64_t kMonotonicOffsetUs = 1'000'000'000;  // CLOCK_MONOTONIC = 1000 s + simulation time

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    const std::size_t end = text.find('\n', start);
    lines.push_back(text.substr(start, end == std::string::npos ? std::string::npos : end - start));
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return lines;
}

struct Frame {
  int index = 0;
  long sequence = 0;
  int64_t stamp_us = 0;
  int64_t got_us = 0;
  double top = 0.0;     // green fraction of the upper half
  double bottom = 0.0;  // and of the lower half
};

std::vector<Frame> frames_of(const std::string& output) {
  std::vector<Frame> frames;
  const std::regex line(R"(frame (\d+) seq=(\d+) stamp_us=(\d+) got_us=(\d+) top=([0-9.]+) bottom=([0-9.]+))");
  for (const std::string& text : lines_of(output)) {
    std::smatch m;
    if (!std::regex_match(text, m, line)) continue;
    frames.push_back({std::stoi(m[1]), std::stol(m[2]), std::stoll(m[3]), std::stoll(m[4]), std::stod(m[5]), std::stod(m[6])});
  }
  return frames;
}

// The camera's frame k: the first 1 ms step at or after k / 30 s (the first step is at 1 ms), in
// microseconds of simulation time.
int64_t due_us(int k) { return std::max<int64_t>(1000, (static_cast<int64_t>(k) * 1'000'000 / 30 + 999) / 1000 * 1000); }

class LockstepVision : public ::testing::Test {
 protected:
  struct Run {
    int code = -1;
    std::string output;
    std::vector<std::string> hashes;
    std::string doppel_output;
  };

  // A fresh doppel --lockstep with the DARwIn-OP and its camera, and `program` (lockstep_vision
  // unless named) with `arguments` under doppel-run --lockstep.
  static Run run(const std::string& arguments, const std::string& program = kVision) {
    const std::string hashes = std::filesystem::temp_directory_path() /
                               ("doppel-vision-hashes-" + std::to_string(::getpid()) + "-" + std::to_string(std::rand()));
    DoppelProcess doppel({"--robot", "darwin-op", "--lockstep", "--lockstep-epoch", "1767225600", "--hashes-file", hashes},
                         "ttyDXL0", /*camera=*/true);
    doppel.wait_for_output("running until");
    Run r;
    std::tie(r.code, r.output) = run_command("timeout 120 " + kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() +
                                             " -- " + program + " " + arguments);
    doppel.stop();
    r.doppel_output = doppel.output();
    std::ifstream in(hashes);
    for (std::string line; std::getline(in, line);) r.hashes.push_back(line);
    std::filesystem::remove(hashes);
    return r;
  }
};

void expect_frames_at_their_times(const std::vector<Frame>& frames, int n) {
  ASSERT_EQ(frames.size(), static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const Frame& f = frames[k];
    EXPECT_EQ(f.sequence, k);
    EXPECT_EQ(f.stamp_us, kMonotonicOffsetUs + due_us(k)) << "frame " << k;
    EXPECT_EQ(f.got_us, f.stamp_us) << "frame " << k;  // dequeued at the simulation time it was ready
  }
}

TEST_F(LockstepVision, AVisionLoopSeesTheSameFramesAtTheSameTimesTwice) {
  constexpr int kFrames = 40;  // 1.33 s: doppel's hash of the first second is in both runs
  const Run first = run("poll /dev/video0 " + std::to_string(kFrames));
  const Run second = run("poll /dev/video0 " + std::to_string(kFrames));
  ASSERT_EQ(first.code, 0) << first.output << first.doppel_output;
  ASSERT_EQ(second.code, 0) << second.output << second.doppel_output;
  const std::vector<Frame> frames = frames_of(first.output);
  expect_frames_at_their_times(frames, kFrames);
  // The robot stands on the carpet with its head camera looking down in front of it: the green
  // carpet fills most of every frame (white lines, the field's other colours take the rest).
  for (const Frame& f : frames) {
    EXPECT_GT(f.top, 0.8) << "frame " << f.index;
    EXPECT_GT(f.bottom, 0.8) << "frame " << f.index;
  }
  EXPECT_NE(first.output.find("frames=40 hash="), std::string::npos) << first.output;
  EXPECT_EQ(first.output, second.output);
  ASSERT_GE(first.hashes.size(), 1u) << first.doppel_output;
  EXPECT_EQ(first.hashes, second.hashes);
}

TEST_F(LockstepVision, PollSelectABlockingDequeueAndReadSeeTheSameFrames) {
  const Run by_poll = run("poll /dev/video0 10");
  const Run by_select = run("select /dev/video0 10");
  const Run by_dqbuf = run("dqbuf /dev/video0 10");
  ASSERT_EQ(by_poll.code, 0) << by_poll.output << by_poll.doppel_output;
  ASSERT_EQ(by_select.code, 0) << by_select.output << by_select.doppel_output;
  ASSERT_EQ(by_dqbuf.code, 0) << by_dqbuf.output << by_dqbuf.doppel_output;
  expect_frames_at_their_times(frames_of(by_dqbuf.output), 10);
  EXPECT_EQ(by_poll.output, by_select.output);
  EXPECT_EQ(by_poll.output, by_dqbuf.output);
  // read(): each call returns the next frame at its simulation time, the same pixels twice.
  const Run by_read = run("read /dev/video0 10");
  const Run by_read_again = run("read /dev/video0 10");
  ASSERT_EQ(by_read.code, 0) << by_read.output << by_read.doppel_output;
  EXPECT_EQ(by_read.output, by_read_again.output);
  const std::regex line(R"(read (\d+) bytes=153600 got_us=(\d+) top=)");
  int reads = 0;
  for (const std::string& text : lines_of(by_read.output)) {
    std::smatch m;
    if (!std::regex_search(text, m, line)) continue;
    EXPECT_EQ(std::stoll(m[2]), kMonotonicOffsetUs + due_us(std::stoi(m[1]))) << text;
    ++reads;
  }
  EXPECT_EQ(reads, 10) << by_read.output;
}

TEST_F(LockstepVision, StreamoffAndRestartGiveAnErrorThenFramesFromSequenceZero) {
  const Run r = run("restart /dev/video0 5");
  ASSERT_EQ(r.code, 0) << r.output << r.doppel_output;
  EXPECT_NE(r.output.find("after_streamoff=Invalid argument"), std::string::npos) << r.output;  // vb2: not streaming
  const std::vector<Frame> frames = frames_of(r.output);
  ASSERT_EQ(frames.size(), 10u) << r.output;
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(frames[k].sequence, k);
    // Restarted at the time of frame 4 (4 / 30 s): the next frames are the camera's 5th onwards.
    EXPECT_EQ(frames[5 + k].sequence, k);
    EXPECT_EQ(frames[5 + k].stamp_us, kMonotonicOffsetUs + due_us(5 + k));
    EXPECT_EQ(frames[5 + k].got_us, frames[5 + k].stamp_us);
  }
}

TEST_F(LockstepVision, AProgramThatNeverDequeuesEndsOnTimeAndASecondOwnerIsRefused) {
  const Run idle = run("idle /dev/video0 5");  // 0.5 s of simulation time streaming, nothing dequeued
  ASSERT_EQ(idle.code, 0) << idle.output << idle.doppel_output;
  EXPECT_NE(idle.output.find("idle_end_us=" + std::to_string(kMonotonicOffsetUs + 500'000)), std::string::npos) << idle.output;
  const Run busy = run("busy /dev/video0 0");
  ASSERT_EQ(busy.code, 0) << busy.output << busy.doppel_output;
  EXPECT_NE(busy.output.find("second_reqbufs=Device or resource busy"), std::string::npos) << busy.output;
}

// Control events (tests/shim/v4l2_events.c, the same checks as in real time) on simulation time: a
// change made by a thread after a 200 ms nanosleep from simulation time 0 is stamped at exactly
// that time, and the blocking DQEVENT waiting for it returns at the next 1 ms step at the latest.
TEST_F(LockstepVision, ControlEventsAreStampedAndDeliveredInSimulationTime) {
  const Run r = run("/dev/video0", V4L2_EVENTS);
  ASSERT_EQ(r.code, 0) << r.output << r.doppel_output;
  EXPECT_NE(r.output.find("\n0 failed\n"), std::string::npos) << r.output;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.output, m, std::regex(R"(set_us=(\d+) event_us=(\d+) woke_us=(\d+))"))) << r.output;
  EXPECT_EQ(std::stoll(m[1]), kMonotonicOffsetUs + 200'000) << r.output;
  EXPECT_EQ(std::stoll(m[2]), std::stoll(m[1])) << r.output;
  EXPECT_GE(std::stoll(m[3]), std::stoll(m[2])) << r.output;
  EXPECT_LE(std::stoll(m[3]), std::stoll(m[2]) + 1000) << r.output;
}

TEST_F(LockstepVision, TwoProgramsOnOneCameraBothGetTheirFrames) {
  // Two processes, each with its own queue (the device of each is its own): neither hangs, each
  // gets every frame at its simulation time from its own STREAMON on.
  const std::string hashes = std::filesystem::temp_directory_path() / ("doppel-vision-two-" + std::to_string(::getpid()));
  DoppelProcess doppel({"--robot", "darwin-op", "--lockstep", "--hashes-file", hashes}, "ttyDXL0", /*camera=*/true);
  doppel.wait_for_output("running until");
  const std::string one = "timeout 120 " + kDoppelRun + " --lockstep --link-dir " + doppel.link_dir() + " -- " + kVision +
                          " poll /dev/video0 20";
  const std::string a = doppel.link_dir() + "/a.txt";
  const std::string b = doppel.link_dir() + "/b.txt";
  const auto [code, output] = run_command(one + " > " + a + " 2>&1 & " + one + " > " + b + " 2>&1; s=$?; wait $!; echo \"exit $s $?\"");
  doppel.stop();
  std::filesystem::remove(hashes);
  EXPECT_NE(output.find("exit 0 0"), std::string::npos) << output << doppel.output();
  for (const std::string& file : {a, b}) {
    std::ifstream in(file);
    const std::string text((std::istreambuf_iterator<char>(in)), {});
    const std::vector<Frame> frames = frames_of(text);
    ASSERT_EQ(frames.size(), 20u) << text;
    for (std::size_t k = 0; k < frames.size(); ++k) {
      EXPECT_EQ(frames[k].sequence, static_cast<long>(k)) << text;
      EXPECT_EQ(frames[k].got_us, frames[k].stamp_us) << text;
      if (k > 0) {
        // One frame per camera period: 33 or 34 ms apart on the 1 ms steps.
        const int64_t gap = frames[k].stamp_us - frames[k - 1].stamp_us;
        EXPECT_TRUE(gap == 33'000 || gap == 34'000) << gap << "\n" << text;
      }
    }
  }
}

}  // namespace
}  // namespace doppel::testing
