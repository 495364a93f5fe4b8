// The simulation-control API's checks (control/http_api.h) against a recording SimControl: what a
// request must look like, that a refused one reaches nothing, and one round trip over a socket.
#include <httplib.h>

#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "control/http_api.h"

namespace doppel::control {
namespace {

class RecordingControl final : public SimControl {
 public:
  SimState state() override {
    SimState s;
    s.sim_time_s = 1.5;
    s.carpet_half_length_m = 5.2;
    s.carpet_half_width_m = 3.7;
    s.ball_m = std::vector<double>{0.0, 0.0, 0.0335};
    RobotState a;
    a.name = "fumanoid-2011";
    a.simulated = true;
    a.joints = {{"neck", 0.25}};
    RobotState b = a;
    b.name = "darwin-op";
    b.simulated = false;
    s.robots = {a, b};
    return s;
  }
  Outcome pause() override { return record("pause"); }
  Outcome resume() override { return record("resume"); }
  Outcome step(uint32_t steps) override { return record("step " + std::to_string(steps)); }
  Outcome reset() override { return record("reset"); }
  Outcome place(std::size_t robot, double x, double y, double yaw) override {
    return record("place " + std::to_string(robot) + " " + std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(yaw));
  }
  Outcome push(std::size_t robot, double fx, double fy, double fz, uint32_t steps) override {
    return record("push " + std::to_string(robot) + " " + std::to_string(fx) + " " + std::to_string(fy) + " " +
                  std::to_string(fz) + " " + std::to_string(steps));
  }
  Outcome ball(double x, double y) override { return record("ball " + std::to_string(x) + " " + std::to_string(y)); }
  std::vector<std::string> calls;

 private:
  Outcome record(const std::string& call) {
    calls.push_back(call);
    return Outcome::done();
  }
};

TEST(HttpApi, StateCarriesTimeRobotsJointsAndBall) {
  RecordingControl control;
  const Answer answer = handle(control, "GET", "/api/state", "");
  ASSERT_EQ(answer.status, 200);
  EXPECT_DOUBLE_EQ(answer.body["sim_time_s"].get<double>(), 1.5);
  EXPECT_EQ(answer.body["paused"], false);
  ASSERT_EQ(answer.body["robots"].size(), 2u);
  EXPECT_EQ(answer.body["robots"][0]["name"], "fumanoid-2011");
  EXPECT_DOUBLE_EQ(answer.body["robots"][0]["joints"]["neck"].get<double>(), 0.25);
  for (const char* key : {"x", "y", "z", "yaw"}) EXPECT_TRUE(answer.body["robots"][0]["pose"].contains(key)) << key;
  EXPECT_EQ(answer.body["robots"][0]["fallen"], false);
  EXPECT_DOUBLE_EQ(answer.body["ball"]["z"].get<double>(), 0.0335);
}

TEST(HttpApi, GoodRequestsReachTheSimulationWithTheirValues) {
  RecordingControl control;
  EXPECT_EQ(handle(control, "POST", "/api/pause", "").status, 200);
  EXPECT_EQ(handle(control, "POST", "/api/step", R"({"ms": 250})").status, 200);
  EXPECT_EQ(handle(control, "POST", "/api/place", R"({"robot": "fumanoid-2011", "x": 1, "y": -0.5, "yaw": 1.5})").status, 200);
  EXPECT_EQ(handle(control, "POST", "/api/push", R"({"robot": 0, "fx": 20, "fy": 0, "fz": 0, "ms": 100})").status, 200);
  EXPECT_EQ(handle(control, "POST", "/api/ball", R"({"x": 0.5, "y": 0})").status, 200);
  EXPECT_EQ(handle(control, "POST", "/api/reset", "{}").status, 200);
  EXPECT_EQ(handle(control, "POST", "/api/resume", "").status, 200);
  EXPECT_EQ(control.calls, (std::vector<std::string>{"pause", "step 250", "place 0 1.000000 -0.500000 1.500000",
                                                     "push 0 20.000000 0.000000 0.000000 100", "ball 0.500000 0.000000",
                                                     "reset", "resume"}));
}

struct Refusal {
  const char* method;
  const char* path;
  const char* body;
  int status;
  const char* reason;  // part of the message
};

TEST(HttpApi, BadRequestsAreRefusedWithTheReasonAndReachNothing) {
  const std::vector<Refusal> refusals = {
      {"POST", "/api/place", "{not json", 400, "not JSON"},
      {"POST", "/api/place", "[1, 2]", 400, "JSON object"},
      {"POST", "/api/place", R"({"robot": 0, "x": 1, "y": 0})", 400, "missing field 'yaw'"},
      {"POST", "/api/place", R"({"robot": 0, "x": 1, "y": 0, "yaw": 0, "yaww": 1})", 400, "unknown field 'yaww'"},
      {"POST", "/api/place", R"({"robot": 0, "x": "1", "y": 0, "yaw": 0})", 400, "'x' must be a number"},
      {"POST", "/api/place", R"({"robot": 7, "x": 1, "y": 0, "yaw": 0})", 404, "no robot 7"},
      {"POST", "/api/place", R"({"robot": "nao", "x": 1, "y": 0, "yaw": 0})", 404, "no robot named 'nao'"},
      {"POST", "/api/place", R"({"robot": 0, "x": 6, "y": 0, "yaw": 0})", 400, "off the carpet"},
      {"POST", "/api/place", R"({"robot": 1, "x": 0, "y": 0, "yaw": 0})", 409, "no body"},
      {"POST", "/api/push", R"({"robot": 0, "fx": 2000, "fy": 0, "fz": 0, "ms": 10})", 400, "more than 1000 N"},
      {"POST", "/api/push", R"({"robot": 0, "fx": 20, "fy": 0, "fz": 0, "ms": 0})", 400, "'ms' must be within 1..10000"},
      {"POST", "/api/push", R"({"robot": 0, "fx": 20, "fy": 0, "fz": 0, "ms": 1.5})", 400, "whole number"},
      {"POST", "/api/step", R"({"ms": 60001})", 400, "within 1..60000"},
      {"POST", "/api/ball", R"({"x": 0, "y": -4})", 400, "off the carpet"},
      {"POST", "/api/pause", R"({"now": true})", 400, "unknown field 'now'"},
      {"POST", "/api/fly", "{}", 404, "no such request"},
      {"POST", "/api/state", "", 405, "GET"},
      {"GET", "/api/pause", "", 405, "POST"},
      {"GET", "/index.php", "", 404, "no such path"},
  };
  for (const Refusal& refusal : refusals) {
    RecordingControl control;
    const Answer answer = handle(control, refusal.method, refusal.path, refusal.body);
    EXPECT_EQ(answer.status, refusal.status) << refusal.path << " " << refusal.body;
    ASSERT_TRUE(answer.body.contains("error")) << refusal.path << " " << refusal.body;
    EXPECT_NE(answer.body["error"].get<std::string>().find(refusal.reason), std::string::npos)
        << answer.body["error"] << " should say " << refusal.reason;
    EXPECT_TRUE(control.calls.empty()) << refusal.path << " " << refusal.body << " reached " << control.calls.front();
  }
}

TEST(HttpApi, TwoRobotsOfOneNameAreAddressedByIndex) {
  class Twins final : public SimControl {
   public:
    SimState state() override {
      SimState s = inner.state();
      s.robots[1] = s.robots[0];
      return s;
    }
    Outcome pause() override { return inner.pause(); }
    Outcome resume() override { return inner.resume(); }
    Outcome step(uint32_t n) override { return inner.step(n); }
    Outcome reset() override { return inner.reset(); }
    Outcome place(std::size_t r, double x, double y, double yaw) override { return inner.place(r, x, y, yaw); }
    Outcome push(std::size_t r, double a, double b, double c, uint32_t n) override { return inner.push(r, a, b, c, n); }
    Outcome ball(double x, double y) override { return inner.ball(x, y); }
    RecordingControl inner;
  } twins;
  const Answer by_name = handle(twins, "POST", "/api/place", R"({"robot": "fumanoid-2011", "x": 0, "y": 0, "yaw": 0})");
  EXPECT_EQ(by_name.status, 400);
  EXPECT_NE(by_name.body["error"].get<std::string>().find("give its index"), std::string::npos);
  EXPECT_EQ(handle(twins, "POST", "/api/place", R"({"robot": 1, "x": 0, "y": 0, "yaw": 0})").status, 200);
}

TEST(HttpApi, ServesOverLoopbackAndRefusesAPortInUse) {
  RecordingControl control;
  HttpApi api(control, "127.0.0.1", 0);
  ASSERT_GT(api.port(), 0);
  api.start();
  httplib::Client client("127.0.0.1", api.port());
  const httplib::Result state = client.Get("/api/state");
  ASSERT_TRUE(state);
  EXPECT_EQ(state->status, 200);
  EXPECT_NE(state->body.find("fumanoid-2011"), std::string::npos);
  const httplib::Result bad = client.Post("/api/step", R"({"ms": -1})", "application/json");
  ASSERT_TRUE(bad);
  EXPECT_EQ(bad->status, 400);

  try {
    HttpApi second(control, "127.0.0.1", api.port());
    FAIL() << "a second server on the same port was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(api.port())), std::string::npos) << e.what();
  }
  api.stop();
  EXPECT_TRUE(control.calls.empty());
}

}  // namespace
}  // namespace doppel::control
