// What the web viewer reads from a running doppel: GET /api/scene (every visible shape, published
// by the simulation thread) and GET /api/buses (every servo's registers, published by its bus
// thread), checked against what the bus and the control API say. Judged on simulation time.
#include <httplib.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <thread>

#include <nlohmann/json.hpp>

#include "doppel_process.h"
#include "reference_client.h"

namespace doppel::testing {
namespace {

using nlohmann::json;

constexpr uint32_t kBaud = 1000000;
constexpr uint8_t kPing = 0x01, kWrite = 0x03;
constexpr uint8_t kTorqueEnable = 24, kGoalPosition = 30;  // Protocol 1.0 control table (RX/MX)

// doppel with its viewer on a port the system picks, and an HTTP client for it.
struct ViewedDoppel {
  explicit ViewedDoppel(std::vector<std::string> args) : doppel([&] {
    args.insert(args.end(), {"--viewer", "0", "--timing", "fast"});
    return args;
  }()) {
    const std::string output = doppel.wait_for_output("viewer on http://127.0.0.1:");
    std::smatch match;
    if (!std::regex_search(output, match, std::regex(R"(viewer on http://127\.0\.0\.1:(\d+)/)"))) {
      throw std::runtime_error("doppel did not say where its viewer is: " + output);
    }
    port = std::stoi(match[1].str());
  }
  json get(const std::string& path) {
    httplib::Client client("127.0.0.1", port);
    client.set_read_timeout(std::chrono::seconds(10));
    client.set_bearer_token_auth(doppel.access_token(static_cast<uint16_t>(port)));
    const httplib::Result result = client.Get(path);
    if (!result || result->status != 200) {
      ADD_FAILURE() << "GET " << path << " failed";
      return json();
    }
    return json::parse(result->body);
  }
  json post(const std::string& path, const json& body) {
    httplib::Client client("127.0.0.1", port);
    client.set_read_timeout(std::chrono::seconds(10));
    client.set_bearer_token_auth(doppel.access_token(static_cast<uint16_t>(port)));
    const httplib::Result result = client.Post(path, body.dump(), "application/json");
    if (!result || result->status != 200) {
      ADD_FAILURE() << "POST " << path << " failed: " << (result ? result->body : "no answer");
      return json();
    }
    return json::parse(result->body);
  }
  // Waits (at most 30 s) until the simulation time reported by /api/state passes `t`.
  void wait_sim_time(double t) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (get("/api/state")["sim_time_s"].get<double>() < t) {
      ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the simulation did not reach " << t << " s";
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  DoppelProcess doppel;
  int port = 0;
};

TEST(ViewerApi, SceneHoldsTheRobotBallAndFieldAndFollowsAPlace) {
  ViewedDoppel doppel({"--physics", "ode"});
  const json scene = doppel.get("/api/scene");
  std::map<std::string, int> kinds;
  for (const json& shape : scene["shapes"]) {
    ++kinds[shape["kind"].get<std::string>()];
    const auto& q = shape["q"];
    const double norm = std::hypot(q[0].get<double>(), q[1].get<double>(), q[2].get<double>());
    EXPECT_NEAR(norm * norm + q[3].get<double>() * q[3].get<double>(), 1.0, 1e-6) << shape.dump();
    if (shape["kind"] == "robot" || shape["kind"] == "team_marker") {
      EXPECT_EQ(shape["object"], 100) << "robot 0";
    }
  }
  EXPECT_GT(kinds["robot"], 5) << "the robot's shapes";
  EXPECT_EQ(kinds["team_marker"], 1);
  EXPECT_EQ(kinds["ball"], 1);
  EXPECT_EQ(kinds["carpet"], 1);
  EXPECT_GT(kinds["line"], 0);
  EXPECT_GT(kinds["goal_post"], 0);

  // Placed elsewhere, the robot's shapes are drawn there once the next scene is out (at most 30
  // times a second of simulation time: 34 ms).
  doppel.post("/api/pause", json::object());
  const json placed = doppel.post("/api/place", {{"robot", 0}, {"x", 1.5}, {"y", -1.0}, {"yaw", 0.0}});
  ASSERT_FALSE(placed.is_null());
  doppel.post("/api/resume", json::object());
  doppel.wait_sim_time(placed["sim_time_s"].get<double>() + 0.1);
  const json after = doppel.get("/api/scene");
  EXPECT_EQ(after["shapes"].size(), scene["shapes"].size()) << "the shape list keeps its size";
  EXPECT_GT(after["sim_time_s"].get<double>(), placed["sim_time_s"].get<double>());
  int robot_shapes = 0;
  for (const json& shape : after["shapes"]) {
    if (shape["kind"] != "robot") continue;
    ++robot_shapes;
    EXPECT_LT(std::hypot(shape["p"][0].get<double>() - 1.5, shape["p"][1].get<double>() + 1.0), 0.4) << shape.dump();
  }
  EXPECT_EQ(robot_shapes, kinds["robot"]);
}

TEST(ViewerApi, ServoTableListsTheBusServosAndFollowsWhatTheDriverWrites) {
  ViewedDoppel doppel({"--physics", "ode"});
  SerialClient client(doppel.doppel.link(), kBaud);
  const json buses = doppel.get("/api/buses");
  ASSERT_EQ(buses.size(), 1u) << buses.dump();
  EXPECT_EQ(buses[0]["robot_name"], "fumanoid-2011");
  EXPECT_EQ(buses[0]["link"], doppel.doppel.link());
  const json& servos = buses[0]["servos"];
  ASSERT_GT(servos.size(), 10u);
  const std::string output = doppel.doppel.output();
  std::set<int> ids;
  for (const json& servo : servos) {
    const int id = servo["id"].get<int>();
    EXPECT_TRUE(ids.insert(id).second) << "ID " << id << " twice";
    EXPECT_FALSE(servo["name"].get<std::string>().empty());
    // The row's servo is on the bus under that ID, and doppel's device list has it with that model and name.
    EXPECT_EQ(client.transact(p1_instruction(static_cast<uint8_t>(id), kPing), 6).size(), 6u) << "ID " << id;
    const std::regex listed("ID +" + std::to_string(id) + " +" + servo["model"].get<std::string>() + " +" +
                            servo["name"].get<std::string>() + "\\b");
    EXPECT_TRUE(std::regex_search(output, listed)) << servo.dump() << "\n" << output;
    EXPECT_EQ(servo["torque"], false) << "power-on: no torque";
    EXPECT_TRUE(servo["error"].is_null()) << "Protocol 1.0 servos have no error register";
    EXPECT_GT(servo["voltage"].get<int>(), 0);
  }
  // The bus counters count the PINGs above: one packet and one reply each, no bad checksum. The
  // bus thread counts a reply's bytes just after writing them, so the last one may still be on its
  // way into the counter when the client already has it: wait a little for it.
  json counters = doppel.get("/api/buses")[0]["counters"];
  for (int i = 0; i < 200 && counters["bytes_out"].get<uint64_t>() < 6 * servos.size(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    counters = doppel.get("/api/buses")[0]["counters"];
  }
  EXPECT_GE(counters["packets"].get<uint64_t>(), servos.size()) << counters.dump();
  EXPECT_GE(counters["replies"].get<uint64_t>(), servos.size()) << counters.dump();
  EXPECT_EQ(counters["bad_checksums"], 0) << counters.dump();
  EXPECT_EQ(counters["collisions"], 0) << counters.dump();
  EXPECT_EQ(counters["connected"], true) << counters.dump();
  EXPECT_GE(counters["bytes_out"].get<uint64_t>(), 6 * servos.size()) << counters.dump();
  // A packet with a wrong checksum is counted as one.
  std::vector<uint8_t> bad = p1_instruction(static_cast<uint8_t>(servos[0]["id"].get<int>()), kPing);
  bad.back() ^= 0x55;
  client.send(bad);
  const auto counted_by = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (doppel.get("/api/buses")[0]["counters"]["bad_checksums"] != 1) {
    ASSERT_LT(std::chrono::steady_clock::now(), counted_by) << "the bad checksum was not counted";
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // The driver turns servo 1 on and sends it to 600: the table shows it within its 100 ms period.
  const int id = servos[0]["id"].get<int>();
  client.send(p1_instruction(static_cast<uint8_t>(id), kWrite, {kGoalPosition, 600 & 0xFF, 600 >> 8}));
  client.send(p1_instruction(static_cast<uint8_t>(id), kWrite, {kTorqueEnable, 1}));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  json row;
  while (true) {
    row = doppel.get("/api/buses")[0]["servos"][0];
    if (row["torque"] == true && row["goal_position"] == 600 && row["present_position"].get<int>() > 560) break;
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the servo table did not follow: " << row.dump();
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

TEST(ViewerApi, AViewerFolderWithoutAPageStopsDoppelNamingIt) {
  const std::string folder = "/tmp/doppel-no-viewer-page-" + std::to_string(::getpid());
  std::filesystem::create_directories(folder);
  const auto [code, output] = run_command(doppel_executable() + " --no-camera --physics none --link-dir " + folder +
                                          "/links --viewer 0 --viewer-dir " + folder);
  EXPECT_NE(code, 0);
  EXPECT_NE(output.find("--viewer-dir: the viewer's folder " + folder + " has no index.html"), std::string::npos) << output;
  std::filesystem::remove_all(folder);
}

TEST(ViewerApi, ServesThePageOfTheNamedFolder) {
  const std::string folder = "/tmp/doppel-viewer-page-" + std::to_string(::getpid());
  std::filesystem::create_directories(folder);
  std::ofstream(folder + "/index.html") << "<title>a team's own viewer</title>";
  ViewedDoppel doppel({"--physics", "none", "--viewer-dir", folder});
  httplib::Client client("127.0.0.1", doppel.port);
  const httplib::Result page = client.Get("/");
  ASSERT_TRUE(page);
  EXPECT_EQ(page->body, "<title>a team's own viewer</title>");
  const httplib::Result three = client.Get("/three/three.min.js");  // Debian's three.js beside it
  ASSERT_TRUE(three);
  EXPECT_EQ(three->status, 200);
  EXPECT_NE(three->body.find("REVISION"), std::string::npos);
  EXPECT_TRUE(doppel.get("/api/scene")["shapes"].empty()) << "no world: nothing to draw";
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace doppel::testing
