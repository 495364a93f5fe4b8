// A recording served as the simulation and replay facets (replay/replay_control.h) and through the HTTP API's
// /api/replay: which recorded message each moment shows (latest-before), play / pause / seek /
// speed against a clock the test drives, world changes refused, bad playback requests refused
// without a half-applied change.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include "control/http_api.h"
#include "recording_fixture.h"
#include "replay/playback.h"
#include "replay/recording.h"
#include "replay/replay_control.h"

namespace doppel::replay {
namespace {

using testing::RecordingFixture;

std::string fixture_path(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("doppel-replay-" + std::to_string(getpid()) + "-" + name)).string();
}

class ReplayControlTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    path_ = fixture_path("two-seconds.mcap");
    testing::write_recording_fixture(path_, RecordingFixture{});
    recording_ = new Recording(path_);
  }
  static void TearDownTestSuite() {
    delete recording_;
    std::filesystem::remove(path_);
  }
  int64_t wall_ns_ = 1'000'000'000'000;
  ReplayControl sut_{*recording_, [this] { return wall_ns_; }};
  static inline std::string path_;
  static inline Recording* recording_ = nullptr;

  void seek(double position_s) {
    contract::ReplayChange change;
    change.position_s = position_s;
    ASSERT_TRUE(sut_.change_replay(change).ok());
  }
};

TEST_F(ReplayControlTest, TheRecordingsTimesAreFromItsFirstMessage) {
  EXPECT_EQ(recording_->origin_ns(), testing::kFixtureOriginNs);
  EXPECT_EQ(recording_->start_ns(), 5'000'000);  // the first world state
  EXPECT_EQ(recording_->end_ns(), 2'000'000'000);
  EXPECT_EQ(recording_->world().size(), 200u);  // 5 ms, 15 ms, ... 1995 ms
  EXPECT_EQ(recording_->scene().size(), 1u);
  EXPECT_EQ(recording_->servos().size(), 21u);
  ASSERT_EQ(recording_->cameras().count("HEAD_CAMERA"), 1u);
  EXPECT_EQ(recording_->run().buses(0).robot_name(), "fumanoid-2011");
  EXPECT_TRUE(recording_->warnings().empty()) << recording_->warnings().front();
  const auto status = sut_.replay();
  EXPECT_DOUBLE_EQ(status.start_s, 0.005);
  EXPECT_DOUBLE_EQ(status.end_s, 2.0);
  EXPECT_FALSE(status.playing);
  EXPECT_EQ(status.cameras, std::vector<std::string>{"HEAD_CAMERA"});
}

TEST_F(ReplayControlTest, StateIsTheLastWorldStateAtOrBeforeThePosition) {
  // World state k is at 5 + 10 k ms with x = 0.001 k: at 1.2049 s the latest is k = 119 (1.195 s).
  seek(1.2049);
  contract::SimState state = sut_.state();
  ASSERT_EQ(state.robots.size(), 1u);
  EXPECT_DOUBLE_EQ(state.robots[0].x_m, testing::fixture_x_m(119));
  EXPECT_DOUBLE_EQ(state.sim_time_s, 0.005 + 0.01 * 119);
  EXPECT_TRUE(state.paused);
  // Exactly on a message's time: that message.
  seek(1.205);
  EXPECT_DOUBLE_EQ(sut_.state().robots[0].x_m, testing::fixture_x_m(120));
  // The robot's joints, IMU and feet come along; the ball too.
  state = sut_.state();
  EXPECT_EQ(state.robots[0].joints.size(), 3u);
  EXPECT_EQ(state.robots[0].imus.size(), 1u);
  EXPECT_EQ(state.robots[0].feet.size(), 2u);
  ASSERT_TRUE(state.ball_m);
  EXPECT_DOUBLE_EQ((*state.ball_m)[2], 0.0335);
  // The carpet (10.4 x 7.4 m in the scene) bounds place and ball as live.
  EXPECT_DOUBLE_EQ(state.carpet_half_length_m, 5.2);
  EXPECT_DOUBLE_EQ(state.carpet_half_width_m, 3.7);
}

TEST_F(ReplayControlTest, PlayingMovesThePositionAtTheChosenSpeedAndStopsAtTheEnd) {
  seek(0.5);
  contract::ReplayChange change;
  change.speed = 2.0;
  change.playing = true;
  ASSERT_TRUE(sut_.change_replay(change).ok());
  wall_ns_ += 250'000'000;  // 0.25 s of wall time at 2x: 0.5 s of recording
  EXPECT_NEAR(sut_.replay().position_s, 1.0, 1e-9);
  EXPECT_FALSE(sut_.state().paused);
  // A speed change keeps the position reached.
  change = {};
  change.speed = 0.5;
  ASSERT_TRUE(sut_.change_replay(change).ok());
  wall_ns_ += 200'000'000;
  EXPECT_NEAR(sut_.replay().position_s, 1.1, 1e-9);
  // Pause holds it.
  ASSERT_TRUE(sut_.pause().ok());
  wall_ns_ += 1'000'000'000;
  EXPECT_NEAR(sut_.replay().position_s, 1.1, 1e-9);
  EXPECT_TRUE(sut_.state().paused);
  // Playing past the end stops there, paused.
  ASSERT_TRUE(sut_.resume().ok());
  wall_ns_ += 10'000'000'000;
  const auto status = sut_.replay();
  EXPECT_DOUBLE_EQ(status.position_s, 2.0);
  EXPECT_FALSE(status.playing);
  EXPECT_DOUBLE_EQ(sut_.state().robots[0].x_m, testing::fixture_x_m(199));
  // Play at the end starts over.
  ASSERT_TRUE(sut_.resume().ok());
  EXPECT_DOUBLE_EQ(sut_.replay().position_s, 0.005);
  EXPECT_TRUE(sut_.replay().playing);
}

TEST_F(ReplayControlTest, StepMovesAPausedReplayAndResetGoesBackToTheStart) {
  seek(1.0);
  ASSERT_TRUE(sut_.step(100).ok());
  EXPECT_NEAR(sut_.replay().position_s, 1.1, 1e-9);
  ASSERT_TRUE(sut_.step(60'000).ok());  // clamped at the end
  EXPECT_DOUBLE_EQ(sut_.replay().position_s, 2.0);
  ASSERT_TRUE(sut_.reset().ok());
  EXPECT_DOUBLE_EQ(sut_.replay().position_s, 0.005);
  ASSERT_TRUE(sut_.resume().ok());
  const contract::Outcome refused = sut_.step(100);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().kind, contract::ErrorKind::kConflict);
  EXPECT_NE(refused.error().message.find("pause first"), std::string::npos) << refused.error().message;
}

TEST_F(ReplayControlTest, SceneIsTheRecordedShapesAtTheirLatestPoses) {
  // Poses k at k * 33.333 ms: at 1.0 s the latest is k = 30 (0.99999999 s... 30 * 33333333 ns).
  seek(1.0);
  const contract::Scene scene = sut_.scene();
  ASSERT_EQ(scene.shapes.size(), 5u);  // carpet, 2 lines, trunk, head
  EXPECT_STREQ(scene.shapes[0].kind, "carpet");
  EXPECT_STREQ(scene.shapes[3].kind, "robot");
  EXPECT_STREQ(scene.shapes[3].type, "box");
  EXPECT_EQ(scene.shapes[3].object_id, 100);
  const double t = 30 * 33'333'333e-9, tilt = testing::fixture_tilt_rad(t, 2.0);
  EXPECT_NEAR(scene.sim_time_s, t, 1e-12);
  EXPECT_NEAR(scene.shapes[3].position[0], 0.1 * t + 0.4 * std::sin(tilt), 1e-12);
  EXPECT_NEAR(scene.shapes[3].quaternion[1], std::sin(tilt / 2), 1e-12);
  EXPECT_EQ(scene.shapes[0].colour[1], 0x80);
}

TEST_F(ReplayControlTest, BusesShowTheLatestServoTableAndTheCountersUpToThePosition) {
  seek(0.75);
  const auto buses = sut_.buses();
  ASSERT_EQ(buses.size(), 1u);
  ASSERT_EQ(buses[0].servos.size(), 3u);
  EXPECT_EQ(buses[0].servos[0].present_position, 7);  // table k = 7 at 700 ms
  EXPECT_EQ(buses[0].servos[0].model, "RX-28");
  // READs every 5 ms from 1 ms: 150 of them up to 746 ms; counters are kept every 10 ms at most.
  const contract::BusCounters& c = buses[0].counters;
  EXPECT_LE(c.packets, 150u);
  EXPECT_GE(c.packets, 148u);
  EXPECT_EQ(c.replies, c.packets);
  EXPECT_EQ(c.bytes_in, 8 * c.packets);
  EXPECT_EQ(c.bytes_out, 8 * c.packets);
  EXPECT_EQ(c.max_lateness_ns, 10'000);
  EXPECT_TRUE(c.connected);
}

TEST_F(ReplayControlTest, CameraStillIsTheLatestRecordedOne) {
  seek(0.8);  // stills at 250 ms, 750 ms, ...
  contract::Result<contract::CameraStill> still = sut_.camera_still("HEAD_CAMERA");
  ASSERT_TRUE(still.ok());
  EXPECT_EQ(still.value().png, "still 1");
  seek(0.1);
  still = sut_.camera_still("HEAD_CAMERA");
  ASSERT_FALSE(still.ok());
  EXPECT_EQ(still.error().kind, contract::ErrorKind::kUnavailable);
  still = sut_.camera_still("TAIL");
  ASSERT_FALSE(still.ok());
  EXPECT_EQ(still.error().kind, contract::ErrorKind::kNotFound);
  EXPECT_NE(still.error().message.find("HEAD_CAMERA"), std::string::npos) << still.error().message;
}

TEST_F(ReplayControlTest, TheApiRefusesWorldChangesWith409AfterTheUsualChecks) {
  for (const auto& [path, body] : std::vector<std::pair<std::string, std::string>>{
           {"/api/place", R"({"robot": 0, "x": 1.0, "y": 0.5, "yaw": 0})"},
           {"/api/push", R"({"robot": 0, "fx": 10, "fy": 0, "fz": 0, "ms": 100})"},
           {"/api/ball", R"({"x": 0.5, "y": 0})"}}) {
    const control::Answer answer = control::handle(sut_.facets(), "POST", path, body);
    EXPECT_EQ(answer.status, 409) << path;
    EXPECT_EQ(answer.body["error"], kReplayCannotChangeWorld) << path;
  }
  // A request that is wrong anyway is told what is wrong with it first.
  EXPECT_EQ(control::handle(sut_.facets(), "POST", "/api/place", R"({"robot": 0, "x": 99, "y": 0, "yaw": 0})").status, 400);
  EXPECT_EQ(control::handle(sut_.facets(), "POST", "/api/place", R"({"robot": 3, "x": 0, "y": 0, "yaw": 0})").status, 404);
}

TEST_F(ReplayControlTest, TheApiChangesPlaybackWithCheckedRequests) {
  control::Answer answer = control::handle(sut_.facets(), "GET", "/api/replay", "");
  ASSERT_EQ(answer.status, 200);
  EXPECT_EQ(answer.body["end_s"], 2.0);
  EXPECT_EQ(answer.body["playing"], false);
  answer = control::handle(sut_.facets(), "POST", "/api/replay", R"({"position_s": 1.5, "speed": 4, "playing": true})");
  ASSERT_EQ(answer.status, 200) << answer.body.dump();
  EXPECT_EQ(answer.body["position_s"], 1.5);
  EXPECT_EQ(answer.body["speed"], 4.0);
  EXPECT_EQ(answer.body["playing"], true);
  wall_ns_ += 100'000'000;
  EXPECT_NEAR(control::handle(sut_.facets(), "GET", "/api/replay", "").body["position_s"].get<double>(), 1.9, 1e-9);
  EXPECT_NEAR(control::handle(sut_.facets(), "GET", "/api/state", "").body["robots"][0]["pose"]["x"].get<double>(),
              testing::fixture_x_m(189), 1e-12);
}

TEST_F(ReplayControlTest, ABadPlaybackRequestChangesNothing) {
  seek(1.0);
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"speed": 2, "position_s": 2.5})", "position_s"},  // past the end; the speed must not apply either
      {R"({"position_s": 0.001})", "position_s"},             // before the first world state
      {R"({"speed": 20})", "speed"},
      {R"({"speed": 0.05})", "speed"},
      {R"({"speed": "fast"})", "speed"},
      {R"({"playing": 1})", "playing"},
      {R"({"volume": 3})", "volume"},
      {R"({})", "position_s"},
      {R"(not json)", "JSON"},
      {R"([1, 2])", "object"},
  };
  for (const auto& [body, named] : bad) {
    const control::Answer answer = control::handle(sut_.facets(), "POST", "/api/replay", body);
    EXPECT_EQ(answer.status, 400) << body;
    EXPECT_NE(answer.body["error"].get<std::string>().find(named), std::string::npos) << body << ": " << answer.body.dump();
  }
  const auto status = sut_.replay();
  EXPECT_DOUBLE_EQ(status.position_s, 1.0);
  EXPECT_DOUBLE_EQ(status.speed, 1.0);
  EXPECT_FALSE(status.playing);
  EXPECT_EQ(control::handle(sut_.facets(), "DELETE", "/api/replay", "").status, 405);
}

// The fixture's bus: a P1 READ of ID 1 (8 bytes) every 5 ms from 1 ms, answered with 8 bytes, at
// 1 Mbps (10 bits a byte: 10 us), no firmware time, RDT or adapter latency recorded.
TEST_F(ReplayControlTest, TheApiServesTheBusAnalysisOfTheRecording) {
  const control::Answer answer = control::handle(sut_.facets(), "GET", "/api/analysis", "");
  ASSERT_EQ(answer.status, 200) << answer.body.dump();
  ASSERT_EQ(answer.body["reports"].size(), 1u);
  const auto& report = answer.body["reports"][0];
  EXPECT_EQ(report["robot_name"], "fumanoid-2011");
  const auto& cycle = report["cycle"];
  ASSERT_EQ(cycle["found"], true);
  EXPECT_EQ(cycle["opener_kind"], "P1 READ");
  EXPECT_EQ(cycle["cycles"], 400);  // 1 ms, 6 ms, ... 1996 ms
  EXPECT_NEAR(cycle["rate_hz"].get<double>(), 200.0, 1e-6);
  EXPECT_NEAR(cycle["period"]["p99_us"].get<double>(), 5000.0, 1e-6);
  EXPECT_NEAR(cycle["period"]["max_us"].get<double>(), 5000.0, 1e-6);
  // Period over time in the replay's time (from the first message): each period at its end.
  const auto& series = report["period_series"];
  ASSERT_EQ(series["t_s"].size(), 399u);
  EXPECT_EQ(series["per_point"], 1);
  EXPECT_NEAR(series["t_s"][0].get<double>(), 0.006, 1e-9);
  EXPECT_NEAR(series["t_s"][398].get<double>(), 1.996, 1e-9);
  EXPECT_NEAR(series["period_us"][0].get<double>(), 5000.0, 1e-6);
  // What if: the default scenarios; the bus alone allows 8 + 8 bytes of 10 us: 160 us, 6250 Hz.
  const auto& what_if = report["what_if"];
  ASSERT_GE(what_if.size(), 2u);
  EXPECT_EQ(what_if[0]["scenario"], "recorded");
  EXPECT_EQ(what_if[1]["scenario"], "driver=recorded");
  EXPECT_NEAR(what_if[0]["rate_hz"].get<double>(), 6250.0, 6250.0 * 0.01);
  EXPECT_EQ(control::handle(sut_.facets(), "POST", "/api/analysis", "{}").status, 405);
}

TEST(ReplayAnalysis, ARecordingWithoutBusTrafficHasNoAnalysis) {
  const std::string path = fixture_path("no-bus.mcap");
  RecordingFixture fixture;
  fixture.transactions_per_s = 0;
  testing::write_recording_fixture(path, fixture);
  {
    const Recording recording(path);
    ReplayControl sut(recording);
    const control::Answer answer = control::handle(sut.facets(), "GET", "/api/analysis", "");
    EXPECT_EQ(answer.status, 404);
    EXPECT_NE(answer.body["error"].get<std::string>().find("no bus analysis"), std::string::npos) << answer.body.dump();
  }
  std::filesystem::remove(path);
}

TEST(Playback, SeekIsClampedAndKeepsPlaying) {
  Playback sut(100, 1000);
  sut.play(0);
  sut.seek(5000, 10);
  EXPECT_EQ(sut.position_ns(10), 1000);
  EXPECT_FALSE(sut.playing(11));
  sut.seek(-5, 20);
  EXPECT_EQ(sut.position_ns(20), 100);
  sut.play(20);
  sut.seek(500, 30);
  EXPECT_TRUE(sut.playing(30));
  EXPECT_EQ(sut.position_ns(130), 600);
}

TEST(ReplayRecording, AFileThatIsNoRecordingIsNamed) {
  const std::string path = fixture_path("not.mcap");
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("hello", f);
    std::fclose(f);
  }
  try {
    Recording sut(path);
    FAIL() << "a text file was read as a recording";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace doppel::replay
