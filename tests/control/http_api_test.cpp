// The simulation-control API's checks (control/http_api.h) against a recording simulation: what a
// request must look like, that a refused one reaches nothing, and one round trip over a socket.
#include <httplib.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "control/http_api.h"

namespace doppel::control {
namespace {

// The facets `fake` implements, offered as a host offers them.
template <typename Fake>
contract::Facets host(Fake& fake) {
  contract::Facets facets;
  facets.simulation = &fake;
  if constexpr (std::is_base_of_v<contract::Game, Fake>) facets.game = &fake;
  if constexpr (std::is_base_of_v<contract::Teamcomm, Fake>) facets.teamcomm = &fake;
  return facets;
}

class RecordingControl : public contract::Simulation {
 public:
  contract::SimState state() override {
    contract::SimState s;
    s.sim_time_s = 1.5;
    s.missed_ticks = 7;
    s.carpet_half_length_m = 5.2;
    s.carpet_half_width_m = 3.7;
    s.ball_m = std::vector<double>{0.0, 0.0, 0.0335};
    contract::RobotState a;
    a.name = "fumanoid-2011";
    a.simulated = true;
    a.joints = {{"neck", 0.25}};
    a.imus = {{"IMU", 0, 200, 0.1, -0.2, {0.5, -0.6, 0.7}}};
    a.feet = {{"FOOT_LEFT", 0, 111, {1.0, 2.0, 3.0, 4.5}}};
    a.cameras = {{"head", {0.1, 0.0, 0.4}, {0.0, 0.0, 0.0, 1.0}, {{{-0.5, -0.4, 0.77}, {0.5, -0.4, 0.77}, {0.5, 0.4, 0.77}, {-0.5, 0.4, 0.77}}}}};
    contract::RobotState b = a;
    b.name = "darwin-op";
    b.simulated = false;
    s.robots = {a, b};
    return s;
  }
  contract::Outcome pause() override { return record("pause"); }
  contract::Outcome resume() override { return record("resume"); }
  contract::Outcome step(uint32_t steps) override { return record("step " + std::to_string(steps)); }
  contract::Outcome reset() override { return record("reset"); }
  contract::Outcome place(std::size_t robot, double x, double y, double yaw) override {
    return record("place " + std::to_string(robot) + " " + std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(yaw));
  }
  contract::Outcome push(std::size_t robot, double fx, double fy, double fz, uint32_t steps) override {
    return record("push " + std::to_string(robot) + " " + std::to_string(fx) + " " + std::to_string(fy) + " " +
                  std::to_string(fz) + " " + std::to_string(steps));
  }
  contract::Outcome ball(double x, double y) override { return record("ball " + std::to_string(x) + " " + std::to_string(y)); }
  contract::Scene scene() override {
    contract::Scene s;
    s.sim_time_s = 2.25;
    contract::SceneShape trunk;
    trunk.type = "box";
    trunk.kind = "robot";
    trunk.object_id = 100;
    trunk.position = {1.0, -0.5, 0.4};
    trunk.quaternion = {0.0, 0.0, 0.7071067811865476, 0.7071067811865476};
    trunk.size = {0.1, 0.16, 0.2};
    trunk.colour = {60, 60, 60};
    s.shapes = {trunk};
    return s;
  }
  std::vector<contract::BusTable> buses() override {
    contract::BusTable bus;
    bus.robot = 0;
    bus.robot_name = "fumanoid-2011";
    bus.bus = 0;
    bus.link = "/tmp/links/ttyDXL0";
    contract::ServoRow p1{1, "HEAD_PITCH", "RX-28", true, 600, 598, 12, 40, 31, 148, -1};
    contract::ServoRow p2{7, "HIP_PITCH", "XM430-W350", false, 2048, 2047, 0, -3, 35, 120, 0x20};
    bus.servos = {p1, p2};
    bus.counters = {1200, 3, 1150, 2, 1, 4, 5, 250'000, 9600, 7200, true};
    return {bus};
  }
  contract::Result<contract::CameraStill> camera_still(const std::string& name) override {
    if (name == "jpeg") return contract::CameraStill{std::string("\xFF\xD8\xFF\xE0", 4) + "jfif", 1.0};  // a replay's recorded JPEG
    if (name != "head") return contract::Error{contract::ErrorKind::kNotFound, "no camera '" + name + "' (robot cameras: head)"};
    return contract::CameraStill{std::string("\x89PNG\r\n\x1a\n", 8) + "pixels", 2.25};
  }
  std::vector<std::string> calls;

 private:
  contract::Outcome record(const std::string& call) {
    calls.push_back(call);
    return contract::Outcome::done();
  }
};

TEST(HttpApi, StateCarriesTimeRobotsJointsAndBall) {
  RecordingControl control;
  const Answer answer = handle(host(control), "GET", "/api/state", "");
  ASSERT_EQ(answer.status, 200);
  EXPECT_DOUBLE_EQ(answer.body["sim_time_s"].get<double>(), 1.5);
  EXPECT_EQ(answer.body["paused"], false);
  EXPECT_EQ(answer.body["missed_ticks"], 7);
  ASSERT_EQ(answer.body["robots"].size(), 2u);
  EXPECT_EQ(answer.body["robots"][0]["name"], "fumanoid-2011");
  EXPECT_DOUBLE_EQ(answer.body["robots"][0]["joints"]["neck"].get<double>(), 0.25);
  for (const char* key : {"x", "y", "z", "yaw"}) EXPECT_TRUE(answer.body["robots"][0]["pose"].contains(key)) << key;
  EXPECT_EQ(answer.body["robots"][0]["fallen"], false);
  EXPECT_DOUBLE_EQ(answer.body["ball"]["z"].get<double>(), 0.0335);
  const auto& imu = answer.body["robots"][0]["imus"][0];
  EXPECT_EQ(imu["name"], "IMU");
  EXPECT_EQ(imu["id"], 200);
  EXPECT_DOUBLE_EQ(imu["roll"].get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(imu["pitch"].get<double>(), -0.2);
  EXPECT_EQ(imu["gyro"], (std::vector<double>{0.5, -0.6, 0.7}));
  const auto& foot = answer.body["robots"][0]["feet"][0];
  EXPECT_EQ(foot["name"], "FOOT_LEFT");
  EXPECT_EQ(foot["id"], 111);
  EXPECT_EQ(foot["cells"], (std::vector<double>{1.0, 2.0, 3.0, 4.5}));
  EXPECT_DOUBLE_EQ(foot["total"].get<double>(), 10.5);
  const auto& camera = answer.body["robots"][0]["cameras"][0];
  EXPECT_EQ(camera["name"], "head");
  EXPECT_EQ(camera["p"], (std::vector<double>{0.1, 0.0, 0.4}));
  EXPECT_EQ(camera["q"], (std::vector<double>{0.0, 0.0, 0.0, 1.0}));
  ASSERT_EQ(camera["corners"].size(), 4u);
  EXPECT_EQ(camera["corners"][2], (std::vector<double>{0.5, 0.4, 0.77}));
}

TEST(HttpApi, GoodRequestsReachTheSimulationWithTheirValues) {
  RecordingControl control;
  EXPECT_EQ(handle(host(control), "POST", "/api/pause", "").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/step", R"({"ms": 250})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/place", R"({"robot": "fumanoid-2011", "x": 1, "y": -0.5, "yaw": 1.5})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/push", R"({"robot": 0, "fx": 20, "fy": 0, "fz": 0, "ms": 100})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/ball", R"({"x": 0.5, "y": 0})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/reset", "{}").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/resume", "").status, 200);
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
    const Answer answer = handle(host(control), refusal.method, refusal.path, refusal.body);
    EXPECT_EQ(answer.status, refusal.status) << refusal.path << " " << refusal.body;
    ASSERT_TRUE(answer.body.contains("error")) << refusal.path << " " << refusal.body;
    EXPECT_NE(answer.body["error"].get<std::string>().find(refusal.reason), std::string::npos)
        << answer.body["error"] << " should say " << refusal.reason;
    EXPECT_TRUE(control.calls.empty()) << refusal.path << " " << refusal.body << " reached " << control.calls.front();
  }
}

TEST(HttpApi, ALiveSimulationIsNoReplay) {
  RecordingControl control;
  for (const char* method : {"GET", "POST"}) {
    const Answer answer = handle(host(control), method, "/api/replay", R"({"playing": true})");
    EXPECT_EQ(answer.status, 404) << method;
    EXPECT_NE(answer.body["error"].get<std::string>().find("not a replay"), std::string::npos) << answer.body.dump();
  }
  EXPECT_TRUE(control.calls.empty());
}

TEST(HttpApi, ALiveSimulationHasNoBusAnalysis) {
  RecordingControl control;
  const Answer answer = handle(host(control), "GET", "/api/analysis", "");
  EXPECT_EQ(answer.status, 404);
  EXPECT_NE(answer.body["error"].get<std::string>().find("doppel-replay"), std::string::npos) << answer.body.dump();
  EXPECT_TRUE(control.calls.empty());
}

// The host refuses in the contract's terms; the API alone turns them into HTTP statuses.
TEST(HttpApi, EachKindOfRefusalHasItsStatusAndKeepsItsMessage) {
  class Refusing final : public RecordingControl {
   public:
    contract::Outcome pause() override { return contract::Outcome::fail(kind, "refused as asked"); }
    contract::ErrorKind kind = contract::ErrorKind::kInvalid;
  } refusing;
  const std::pair<contract::ErrorKind, int> kinds[] = {{contract::ErrorKind::kInvalid, 400},
                                                       {contract::ErrorKind::kNotFound, 404},
                                                       {contract::ErrorKind::kConflict, 409},
                                                       {contract::ErrorKind::kUnavailable, 503}};
  for (const auto& [kind, status] : kinds) {
    EXPECT_EQ(http_status(kind), status);
    refusing.kind = kind;
    const Answer answer = handle(host(refusing), "POST", "/api/pause", "");
    EXPECT_EQ(answer.status, status);
    EXPECT_EQ(answer.body, (nlohmann::json{{"error", "refused as asked"}}));
  }
}

// Paths the routes' patterns do not take whole get 404 naming the path, before any facet is asked.
TEST(HttpApi, APathOutsideTheRoutesIsNotFound) {
  RecordingControl control;
  for (const char* path : {"/api/robots/1234567/world_model", "/api/robots/x/world_model", "/api/faults/1/2",
                           "/api/teamcomm/robots/7", "/api/teamcomm/robotsX", "/state", "/api"}) {
    const Answer answer = handle(host(control), "DELETE", path, "");
    EXPECT_EQ(answer.status, 404) << path;
    EXPECT_TRUE(answer.body.contains("error")) << path;
  }
  EXPECT_TRUE(control.calls.empty());
}

TEST(HttpApi, TwoRobotsOfOneNameAreAddressedByIndex) {
  class Twins final : public contract::Simulation {
   public:
    contract::SimState state() override {
      contract::SimState s = inner.state();
      s.robots[1] = s.robots[0];
      return s;
    }
    contract::Outcome pause() override { return inner.pause(); }
    contract::Outcome resume() override { return inner.resume(); }
    contract::Outcome step(uint32_t n) override { return inner.step(n); }
    contract::Outcome reset() override { return inner.reset(); }
    contract::Outcome place(std::size_t r, double x, double y, double yaw) override { return inner.place(r, x, y, yaw); }
    contract::Outcome push(std::size_t r, double a, double b, double c, uint32_t n) override { return inner.push(r, a, b, c, n); }
    contract::Outcome ball(double x, double y) override { return inner.ball(x, y); }
    contract::Scene scene() override { return inner.scene(); }
    std::vector<contract::BusTable> buses() override { return inner.buses(); }
    contract::Result<contract::CameraStill> camera_still(const std::string& name) override { return inner.camera_still(name); }
    RecordingControl inner;
  } twins;
  const Answer by_name = handle(host(twins), "POST", "/api/place", R"({"robot": "fumanoid-2011", "x": 0, "y": 0, "yaw": 0})");
  EXPECT_EQ(by_name.status, 400);
  EXPECT_NE(by_name.body["error"].get<std::string>().find("give its index"), std::string::npos);
  EXPECT_EQ(handle(host(twins), "POST", "/api/place", R"({"robot": 1, "x": 0, "y": 0, "yaw": 0})").status, 200);
}

// A URDF mesh's hull goes to the page as its vertices and triangles, which the viewer draws.
TEST(HttpApi, AConvexHullCarriesItsVerticesAndTriangles) {
  contract::Scene scene;
  contract::SceneShape hull;
  hull.type = "convex";
  hull.vertices = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  hull.triangles = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  scene.shapes = {hull, contract::SceneShape{}};
  const nlohmann::json json = scene_json(scene);
  EXPECT_EQ(json["shapes"][0]["type"], "convex");
  EXPECT_EQ(json["shapes"][0]["vertices"].size(), 12u);
  EXPECT_EQ(json["shapes"][0]["triangles"].get<std::vector<unsigned>>(), hull.triangles);
  EXPECT_FALSE(json["shapes"][1].contains("vertices")) << "a box carries no mesh";
}

TEST(HttpApi, SceneCarriesEveryShapeWithPoseSizeAndColour) {
  RecordingControl control;
  const Answer answer = handle(host(control), "GET", "/api/scene", "");
  ASSERT_EQ(answer.status, 200);
  EXPECT_DOUBLE_EQ(answer.body["sim_time_s"].get<double>(), 2.25);
  ASSERT_EQ(answer.body["shapes"].size(), 1u);
  const auto& shape = answer.body["shapes"][0];
  EXPECT_EQ(shape["type"], "box");
  EXPECT_EQ(shape["kind"], "robot");
  EXPECT_EQ(shape["object"], 100);
  EXPECT_EQ(shape["p"], (std::vector<double>{1.0, -0.5, 0.4}));
  EXPECT_DOUBLE_EQ(shape["q"][3].get<double>(), 0.7071067811865476);  // x, y, z, w: w last
  EXPECT_EQ(shape["size"], (std::vector<double>{0.1, 0.16, 0.2}));
  EXPECT_EQ(shape["rgb"], (std::vector<int>{60, 60, 60}));
  EXPECT_EQ(handle(host(control), "POST", "/api/scene", "").status, 405);
  EXPECT_TRUE(control.calls.empty());
}

TEST(HttpApi, BusesCarryEveryServosRegistersAndNoErrorRegisterAsNull) {
  RecordingControl control;
  const Answer answer = handle(host(control), "GET", "/api/buses", "");
  ASSERT_EQ(answer.status, 200);
  ASSERT_EQ(answer.body.size(), 1u);
  const auto& bus = answer.body[0];
  EXPECT_EQ(bus["robot_name"], "fumanoid-2011");
  EXPECT_EQ(bus["link"], "/tmp/links/ttyDXL0");
  ASSERT_EQ(bus["servos"].size(), 2u);
  const auto& p1 = bus["servos"][0];
  EXPECT_EQ(p1["id"], 1);
  EXPECT_EQ(p1["name"], "HEAD_PITCH");
  EXPECT_EQ(p1["model"], "RX-28");
  EXPECT_EQ(p1["torque"], true);
  EXPECT_EQ(p1["goal_position"], 600);
  EXPECT_EQ(p1["present_position"], 598);
  EXPECT_EQ(p1["present_speed"], 12);
  EXPECT_EQ(p1["present_load"], 40);
  EXPECT_EQ(p1["temperature"], 31);
  EXPECT_EQ(p1["voltage"], 148);
  EXPECT_TRUE(p1["error"].is_null());  // Protocol 1.0: no error register
  EXPECT_EQ(bus["servos"][1]["error"], 0x20);
  EXPECT_EQ(bus["servos"][1]["present_load"], -3);
  const auto& counters = bus["counters"];
  EXPECT_EQ(counters["packets"], 1200);
  EXPECT_EQ(counters["bad_checksums"], 3);
  EXPECT_EQ(counters["replies"], 1150);
  EXPECT_EQ(counters["collisions"], 2);
  EXPECT_EQ(counters["dropped_replies"], 1);
  EXPECT_EQ(counters["timeouts"], 4);
  EXPECT_EQ(counters["late_deliveries"], 5);
  EXPECT_DOUBLE_EQ(counters["max_lateness_us"].get<double>(), 250.0);
  EXPECT_EQ(counters["bytes_in"], 9600);
  EXPECT_EQ(counters["bytes_out"], 7200);
  EXPECT_EQ(counters["connected"], true);
  EXPECT_EQ(handle(host(control), "POST", "/api/buses", "").status, 405);
}

// A folder under the test's temporary directory holding `files` (name -> content).
std::string folder_with(const std::string& name, const std::vector<std::pair<std::string, std::string>>& files) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("doppel-http-api-test-" + std::to_string(::getpid())) / name;
  std::filesystem::create_directories(dir);
  for (const auto& [file, content] : files) std::ofstream(dir / file) << content;
  return dir.string();
}

TEST(HttpApi, ServesTheViewerPageAndThreeJsBesideTheApi) {
  RecordingControl control;
  const StaticFiles files{folder_with("viewer", {{"index.html", "<title>viewer page</title>"}, {"viewer.js", "let x = 1;"}}),
                          folder_with("three", {{"three.min.js", "var THREE = {};"}})};
  ASSERT_EQ(static_files_problem(files), "");
  HttpApi api(host(control), "127.0.0.1", 0, files);
  api.start();
  httplib::Client client("127.0.0.1", api.port());
  const httplib::Result page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->status, 200);
  EXPECT_EQ(page->body, "<title>viewer page</title>");
  const httplib::Result script = client.Get("/viewer.js");
  ASSERT_TRUE(script);
  EXPECT_EQ(script->body, "let x = 1;");
  const httplib::Result three = client.Get("/three/three.min.js");
  ASSERT_TRUE(three);
  EXPECT_EQ(three->body, "var THREE = {};");
  const httplib::Result scene = client.Get("/api/scene");  // the API answers beside the files
  ASSERT_TRUE(scene);
  EXPECT_EQ(scene->status, 200);
  EXPECT_EQ(nlohmann::json::parse(scene->body)["shapes"].size(), 1u);
  const httplib::Result missing = client.Get("/no-such-file.js");
  ASSERT_TRUE(missing);
  EXPECT_EQ(missing->status, 404);
  api.stop();
  std::filesystem::remove_all(std::filesystem::path(files.viewer_dir).parent_path());
}

TEST(HttpApi, AViewerFolderWithoutItsFilesIsNamed) {
  RecordingControl control;
  const std::string empty = folder_with("empty", {});
  const std::string problem = static_files_problem({empty, ""});
  EXPECT_NE(problem.find(empty), std::string::npos) << problem;
  EXPECT_NE(problem.find("index.html"), std::string::npos) << problem;
  const std::string no_three = static_files_problem({"", empty});
  EXPECT_NE(no_three.find("libjs-three"), std::string::npos) << no_three;
  EXPECT_THROW(HttpApi(host(control), "127.0.0.1", 0, {empty, ""}), std::runtime_error);
  std::filesystem::remove_all(std::filesystem::path(empty).parent_path());
}

TEST(HttpApi, TheDefaultViewerFolderIsTheSourceTreesUnlessTheEnvironmentNamesOne) {
  ::unsetenv("DOPPEL_VIEWER_DIR");
  ::unsetenv("DOPPEL_THREE_DIR");
  const StaticFiles defaults = default_static_files();
  EXPECT_TRUE(std::filesystem::is_regular_file(std::filesystem::path(defaults.viewer_dir) / "index.html")) << defaults.viewer_dir;
  EXPECT_EQ(defaults.three_dir, "/usr/share/javascript/three");
  ::setenv("DOPPEL_VIEWER_DIR", "/elsewhere/viewer", 1);
  ::setenv("DOPPEL_THREE_DIR", "/elsewhere/three", 1);
  const StaticFiles named = default_static_files();
  EXPECT_EQ(named.viewer_dir, "/elsewhere/viewer");
  EXPECT_EQ(named.three_dir, "/elsewhere/three");
  ::unsetenv("DOPPEL_VIEWER_DIR");
  ::unsetenv("DOPPEL_THREE_DIR");
}

TEST(HttpApi, ServesOverLoopbackAndRefusesAPortInUse) {
  RecordingControl control;
  HttpApi api(host(control), "127.0.0.1", 0);
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
    HttpApi second(host(control), "127.0.0.1", api.port());
    FAIL() << "a second server on the same port was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(api.port())), std::string::npos) << e.what();
  }
  api.stop();
  EXPECT_TRUE(control.calls.empty());
}

TEST(HttpApi, ACamerasStillIsServedAsPngAndAnUnknownCameraIsNamed) {
  RecordingControl control;
  HttpApi api(host(control), "127.0.0.1", 0);
  api.start();
  httplib::Client client("127.0.0.1", api.port());
  const httplib::Result still = client.Get("/api/camera/head");
  ASSERT_TRUE(still);
  EXPECT_EQ(still->status, 200);
  EXPECT_EQ(still->get_header_value("Content-Type"), "image/png");
  EXPECT_EQ(still->get_header_value("Cache-Control"), "no-store");
  EXPECT_EQ(still->body, std::string("\x89PNG\r\n\x1a\n", 8) + "pixels");
  EXPECT_DOUBLE_EQ(std::stod(still->get_header_value("X-Sim-Time")), 2.25);
  const httplib::Result unknown = client.Get("/api/camera/tail");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status, 404);
  EXPECT_EQ(nlohmann::json::parse(unknown->body)["error"], "no camera 'tail' (robot cameras: head)");
  const httplib::Result jpeg = client.Get("/api/camera/jpeg");
  ASSERT_TRUE(jpeg);
  EXPECT_EQ(jpeg->get_header_value("Content-Type"), "image/jpeg");
  api.stop();
}

// The checks over a socket (control/access.h): what a web page, a rebinding name or a request
// without the token gets, and that none of it reaches the simulation.
TEST(HttpApi, RefusesForeignHostsOriginsPlainTextAndMissingTokensBeforeAnythingRuns) {
  RecordingControl control;
  const std::string token = contract::new_access_token();
  HttpApi api(host(control), "127.0.0.1", 0, {}, token);
  api.start();
  const std::string self = "127.0.0.1:" + std::to_string(api.port());
  auto send = [&](const std::string& method, const std::string& path, httplib::Headers headers, const std::string& type,
                  const std::string& body = "{}") {
    httplib::Client client("127.0.0.1", api.port());
    client.set_read_timeout(std::chrono::seconds(10));
    httplib::Request request;
    request.method = method;
    request.path = path;
    request.headers = std::move(headers);
    if (!type.empty()) request.set_header("Content-Type", type);
    if (method != "GET") request.body = body;
    return client.send(request);
  };
  const httplib::Headers bearer = {{"Authorization", "Bearer " + token}};

  // The issue's two requests: a "simple" cross-origin POST, and a rebinding name's read.
  httplib::Headers page = bearer;
  page.emplace("Origin", "http://evil.example");
  httplib::Result r = send("POST", "/api/pause", page, "text/plain");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  r = send("POST", "/api/pause", page, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  r = send("POST", "/api/pause", bearer, "text/plain");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_NE(nlohmann::json::parse(r->body)["error"].get<std::string>().find("application/json"), std::string::npos);
  httplib::Headers rebound = bearer;
  rebound.emplace("Host", "attacker.example:" + std::to_string(api.port()));
  r = send("GET", "/api/state", rebound, "");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 403);
  EXPECT_EQ(r->body.find("fumanoid"), std::string::npos);
  EXPECT_TRUE(r->get_header_value("Access-Control-Allow-Origin").empty());

  // Without the token, or with a wrong one: 401, nothing read or changed.
  for (const httplib::Headers& headers : {httplib::Headers{}, httplib::Headers{{"Authorization", "Bearer " + std::string(32, '0')}},
                                          httplib::Headers{{"X-Doppel-Token", "x"}}, httplib::Headers{{"Cookie", "doppel_token_1=" + token}}}) {
    r = send("POST", "/api/pause", headers, "application/json");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 401);
    r = send("GET", "/api/state", headers, "");
    ASSERT_TRUE(r);
    EXPECT_EQ(r->status, 401);
    EXPECT_EQ(r->body.find("fumanoid"), std::string::npos);
  }
  EXPECT_TRUE(control.calls.empty());

  // The user's own requests: the token as a header, as the page's cookie, from the printed link.
  r = send("POST", "/api/pause", bearer, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  r = send("GET", "/api/state", {{"X-Doppel-Token", token}}, "");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  httplib::Headers own_page = {{"Cookie", "doppel_token_" + std::to_string(api.port()) + "=" + token},
                               {"Origin", "http://" + self}};
  r = send("POST", "/api/resume", own_page, "application/json");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  r = send("GET", "/api/state?token=" + token, {}, "");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  const std::string cookie = r->get_header_value("Set-Cookie");
  EXPECT_EQ(cookie, "doppel_token_" + std::to_string(api.port()) + "=" + token + "; Path=/; HttpOnly; SameSite=Strict");
  EXPECT_EQ(control.calls, (std::vector<std::string>{"pause", "resume"}));

  // Requests no client should send do not stop the server.
  for (const std::string& junk : {std::string(8000, 'x'), std::string("\x01\x02\xff"), std::string("Bearer")}) {
    r = send("POST", "/api/reset", {{"Authorization", junk}, {"Origin", junk}, {"Cookie", junk}}, junk);
    ASSERT_TRUE(r);
    EXPECT_GE(r->status, 400);
  }
  EXPECT_EQ(control.calls.size(), 2u);
  r = send("GET", "/api/state", bearer, "");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 200);
  api.stop();
}

}  // namespace
}  // namespace doppel::control

namespace doppel::control {
namespace {

// A GameController and a hub as their facets report them, recording what reaches them.
class GameControl final : public contract::Simulation, public contract::Game, public contract::Teamcomm {
 public:
  contract::SimState state() override { return {}; }
  contract::Outcome pause() override { return contract::Outcome::done(); }
  contract::Outcome resume() override { return contract::Outcome::done(); }
  contract::Outcome step(uint32_t) override { return contract::Outcome::done(); }
  contract::Outcome reset() override { return contract::Outcome::done(); }
  contract::Outcome place(std::size_t, double, double, double) override { return contract::Outcome::done(); }
  contract::Outcome push(std::size_t, double, double, double, uint32_t) override { return contract::Outcome::done(); }
  contract::Outcome ball(double, double) override { return contract::Outcome::done(); }
  contract::Scene scene() override { return {}; }
  std::vector<contract::BusTable> buses() override { return {}; }
  contract::Result<contract::CameraStill> camera_still(const std::string&) override {
    return contract::Error{contract::ErrorKind::kNotFound, "no camera"};
  }
  contract::GameStatus game() override {
    contract::GameStatus s;
    s.on = true;
    s.sending = true;
    s.state = "ready";
    s.teams[0].number = 12;
    s.teams[0].score = 2;
    s.teams[1].number = 34;
    s.teams[1].penalties = {{3, 34, "pickup_or_incapable", 17}};
    s.returns = {{12, 1, "alive", 9, 0.25}};
    return s;
  }
  contract::Outcome game_command(const contract::GameCommand& c) override {
    calls.push_back(c.command + " " + c.state + " team " + std::to_string(c.team) + " player " + std::to_string(c.player) +
                    " seconds " + std::to_string(c.seconds) + " penalty " + std::to_string(c.penalty) + " score " +
                    std::to_string(c.score) + " " + c.set_play + " mode " + std::to_string(c.mode));
    if (c.command == "state" && c.state == "set") {
      return contract::Outcome::fail(contract::ErrorKind::kConflict, "set is not allowed in INITIAL");
    }
    return contract::Outcome::done();
  }
  std::optional<contract::TeamcommStatus> teamcomm() override {
    contract::TeamcommStatus s;
    s.listen = "127.0.0.1:3737";
    s.robots = {{7, 1, 44001}};
    return s;
  }
  contract::Outcome teamcomm_add(const contract::TeamcommRobot& r) override {
    calls.push_back("add " + std::to_string(r.team) + ":" + std::to_string(r.player) + ":" + std::to_string(r.port));
    return contract::Outcome::done();
  }
  contract::Outcome teamcomm_remove(int team, int player) override {
    calls.push_back("remove " + std::to_string(team) + ":" + std::to_string(player));
    if (team == 9) return contract::Outcome::fail(contract::ErrorKind::kNotFound, "no robot 9:1 is registered");
    return contract::Outcome::done();
  }
  std::vector<std::string> calls;
};

TEST(HttpApiGame, StatusCarriesScoresPenaltiesAndReturns) {
  GameControl control;
  const Answer answer = handle(host(control), "GET", "/api/game", "");
  ASSERT_EQ(answer.status, 200);
  EXPECT_EQ(answer.body["state"], "ready");
  EXPECT_EQ(answer.body["teams"][0]["number"], 12);
  EXPECT_EQ(answer.body["teams"][0]["score"], 2);
  EXPECT_EQ(answer.body["teams"][1]["penalties"][0]["player"], 3);
  EXPECT_EQ(answer.body["teams"][1]["penalties"][0]["seconds_left"], 17);
  EXPECT_EQ(answer.body["teams"][1]["penalties"][0]["reason"], "pickup_or_incapable");
  EXPECT_EQ(answer.body["returns"][0]["message"], "alive");
  EXPECT_EQ(answer.body["returns"][0]["count"], 9);
  EXPECT_TRUE(answer.body["foreign"].is_null());
}

TEST(HttpApiGame, GoodCommandsReachTheGameWithTheirValues) {
  GameControl control;
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "state", "state": "ready"})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "goal", "team": "B"})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "score", "team": 12, "score": 5})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "kickoff", "team": "drop_ball"})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game",
                   R"({"command": "penalize", "team": "A", "player": 2, "seconds": 45, "reason": "physical_contact"})")
                .status,
            200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "unpenalize", "team": 34, "player": 11})").status, 200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "set_play", "kind": "corner_kick", "team": "A", "mode": 1})").status,
            200);
  EXPECT_EQ(handle(host(control), "POST", "/api/game", R"({"command": "off"})").status, 200);
  // The game's own refusal comes back as it said it.
  const Answer refused = handle(host(control), "POST", "/api/game", R"({"command": "state", "state": "set"})");
  EXPECT_EQ(refused.status, 409);
  EXPECT_EQ(refused.body["error"], "set is not allowed in INITIAL");
  EXPECT_EQ(control.calls, (std::vector<std::string>{
                               "state ready team -1 player 0 seconds 30 penalty 34 score 0  mode 0",
                               "goal  team 1 player 0 seconds 30 penalty 34 score 0  mode 0",
                               "score  team 0 player 0 seconds 30 penalty 34 score 5  mode 0",
                               "kickoff  team -1 player 0 seconds 30 penalty 34 score 0  mode 0",
                               "penalize  team 0 player 2 seconds 45 penalty 31 score 0  mode 0",
                               "unpenalize  team 1 player 11 seconds 30 penalty 34 score 0  mode 0",
                               "set_play  team 0 player 0 seconds 30 penalty 34 score 0 corner_kick mode 1",
                               "off  team -1 player 0 seconds 30 penalty 34 score 0  mode 0",
                               "state set team -1 player 0 seconds 30 penalty 34 score 0  mode 0"}));
}

TEST(HttpApiGame, BadCommandsNameTheFieldAndReachNothing) {
  GameControl control;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"command": "fly"})", "'command'"},
      {R"({"state": "ready"})", "missing field 'command'"},
      {R"({"command": "state", "state": "halftime"})", "'state'"},
      {R"({"command": "state"})", "missing field 'state'"},
      {R"({"command": "goal", "team": "C"})", "'team'"},
      {R"({"command": "goal", "team": 99})", "'team'"},
      {R"({"command": "penalize", "team": "A", "player": 12})", "'player'"},
      {R"({"command": "penalize", "team": "A", "player": 0})", "'player'"},
      {R"({"command": "penalize", "team": "A", "player": 1, "seconds": 300})", "'seconds'"},
      {R"({"command": "penalize", "team": "A", "player": 1, "reason": "rudeness"})", "'reason'"},
      {R"({"command": "penalize", "team": "A", "player": "one"})", "'player'"},
      {R"({"command": "score", "team": "A", "score": 256})", "'score'"},
      {R"({"command": "set_play", "kind": "kick_in", "team": "A"})", "'kind'"},
      {R"({"command": "on", "state": "ready"})", "unknown field 'state'"},
      {R"([1, 2])", "JSON object"},
  };
  for (const auto& [body, field] : bad) {
    const Answer answer = handle(host(control), "POST", "/api/game", body);
    EXPECT_EQ(answer.status, 400) << body;
    EXPECT_NE(answer.body["error"].get<std::string>().find(field), std::string::npos) << body << " -> " << answer.body;
  }
  EXPECT_TRUE(control.calls.empty());
  EXPECT_EQ(handle(host(control), "DELETE", "/api/game", "").status, 405);
}

TEST(HttpApiGame, WithoutAGameControllerTheApiSaysSo) {
  RecordingControl control;  // a simulation that offers neither
  const Answer answer = handle(host(control), "GET", "/api/game", "");
  EXPECT_EQ(answer.status, 404);
  EXPECT_NE(answer.body["error"].get<std::string>().find("no GameController"), std::string::npos);
  EXPECT_EQ(handle(host(control), "GET", "/api/teamcomm", "").status, 404);
  EXPECT_EQ(handle(host(control), "POST", "/api/teamcomm/robots", R"({"team": 1, "player": 1, "port": 4000})").status, 404);
}

TEST(HttpApiTeamcomm, RobotsAreRegisteredAndRemovedAndBadOnesNameTheField) {
  GameControl control;
  const Answer status = handle(host(control), "GET", "/api/teamcomm", "");
  ASSERT_EQ(status.status, 200);
  EXPECT_EQ(status.body["listen"], "127.0.0.1:3737");
  EXPECT_EQ(handle(host(control), "GET", "/api/teamcomm/robots", "").body[0]["port"], 44001);
  EXPECT_EQ(handle(host(control), "POST", "/api/teamcomm/robots", R"({"team": 7, "player": 2, "port": 44002})").status, 200);
  EXPECT_EQ(handle(host(control), "DELETE", "/api/teamcomm/robots/7/2", "").status, 200);
  const Answer missing = handle(host(control), "DELETE", "/api/teamcomm/robots/9/1", "");
  EXPECT_EQ(missing.status, 404);
  EXPECT_EQ(missing.body["error"], "no robot 9:1 is registered");
  EXPECT_EQ(control.calls, (std::vector<std::string>{"add 7:2:44002", "remove 7:2", "remove 9:1"}));
  control.calls.clear();
  const std::vector<std::pair<std::string, std::string>> bad = {
      {R"({"team": 7, "player": 2, "port": 0})", "'port'"},
      {R"({"team": 7, "player": 2, "port": 70000})", "'port'"},
      {R"({"team": 256, "player": 2, "port": 4000})", "'team'"},
      {R"({"team": 7, "port": 4000})", "missing field 'player'"},
      {R"({"team": 7, "player": 2, "port": 4000, "address": "10.0.0.1"})", "unknown field 'address'"},
  };
  for (const auto& [body, field] : bad) {
    const Answer answer = handle(host(control), "POST", "/api/teamcomm/robots", body);
    EXPECT_EQ(answer.status, 400) << body;
    EXPECT_NE(answer.body["error"].get<std::string>().find(field), std::string::npos) << body << " -> " << answer.body;
  }
  const Answer bad_path = handle(host(control), "DELETE", "/api/teamcomm/robots/7/x", "");
  EXPECT_EQ(bad_path.status, 400);
  EXPECT_NE(bad_path.body["error"].get<std::string>().find("player 'x'"), std::string::npos) << bad_path.body;
  EXPECT_TRUE(control.calls.empty());
}

}  // namespace
}  // namespace doppel::control
