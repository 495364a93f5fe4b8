#include "replay/replay_control.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>

#include "replay/bus_analysis.h"

namespace doppel::replay {
namespace {

int64_t monotonic_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

double seconds(int64_t ns) { return static_cast<double>(ns) * 1e-9; }

contract::SimState decode_world(std::string_view bytes, bool& ok) {
  recording::WorldState world;
  ok = world.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()));
  contract::SimState state;
  state.sim_time_s = world.sim_time_s();
  state.missed_ticks = world.missed_ticks();
  if (world.has_ball()) state.ball_m = std::vector<double>{world.ball().x(), world.ball().y(), world.ball().z()};
  for (const recording::RobotState& r : world.robots()) {
    contract::RobotState robot;
    robot.name = r.name();
    robot.simulated = true;  // the recorder writes the robots of the world
    robot.x_m = r.x_m();
    robot.y_m = r.y_m();
    robot.z_m = r.z_m();
    robot.yaw_rad = r.yaw_rad();
    robot.tilt_rad = r.tilt_rad();
    robot.fallen = r.fallen();
    robot.held = r.held();
    for (const recording::Joint& j : r.joints()) robot.joints.push_back({j.name(), j.position_rad()});
    for (const recording::Imu& i : r.imus()) {
      robot.imus.push_back({i.name(), i.bus(), static_cast<uint8_t>(i.id()), i.roll_rad(), i.pitch_rad(),
                            {i.gyro_rad_s().x(), i.gyro_rad_s().y(), i.gyro_rad_s().z()}});
    }
    for (const recording::Foot& f : r.feet()) {
      contract::FootReading foot{f.name(), f.bus(), static_cast<uint8_t>(f.id()), {}};
      for (int k = 0; k < std::min(4, f.force_n_size()); ++k) foot.force_n[k] = f.force_n(k);
      robot.feet.push_back(foot);
    }
    state.robots.push_back(std::move(robot));
  }
  return state;
}

}  // namespace

ReplayControl::ReplayControl(const Recording& recording, Clock clock)
    : recording_(recording),
      clock_(clock ? std::move(clock) : Clock(monotonic_ns)),
      playback_(recording.start_ns(), recording.end_ns()) {
  // The carpet bounds the place and ball requests check (they are refused anyway, after the checks).
  if (!recording_.scene().empty()) {
    recording::Scene first;
    const std::string_view bytes = recording_.scene().bytes(0);
    if (first.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
      for (const recording::Shape& shape : first.shapes()) {
        if (shape.kind() != "carpet") continue;
        carpet_half_length_m_ = std::max(carpet_half_length_m_, shape.size().x() / 2.0);
        carpet_half_width_m_ = std::max(carpet_half_width_m_, shape.size().y() / 2.0);
      }
    }
  }
}

int64_t ReplayControl::position_locked() { return playback_.position_ns(now_ns()); }

const char* ReplayControl::intern(const std::string& text) { return strings_.insert(text).first->c_str(); }

contract::SimState ReplayControl::state() {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t position = position_locked();
  const std::optional<std::size_t> index = recording_.world().at_or_before(position);
  if (index != world_index_) {
    world_ = {};
    if (index) {
      bool ok = false;
      world_ = decode_world(recording_.world().bytes(*index), ok);
    }
    world_index_ = index;
  }
  contract::SimState state = world_;
  state.paused = !playback_.playing(now_ns());
  state.carpet_half_length_m = carpet_half_length_m_;
  state.carpet_half_width_m = carpet_half_width_m_;
  return state;
}

contract::Outcome ReplayControl::pause() {
  std::lock_guard<std::mutex> lock(mutex_);
  playback_.pause(now_ns());
  return contract::Outcome::done();
}

contract::Outcome ReplayControl::resume() {
  std::lock_guard<std::mutex> lock(mutex_);
  playback_.play(now_ns());
  return contract::Outcome::done();
}

contract::Outcome ReplayControl::step(uint32_t steps) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = now_ns();
  if (playback_.playing(now)) return contract::Outcome::fail(contract::ErrorKind::kConflict, "the replay is playing: pause first");
  playback_.seek(playback_.position_ns(now) + static_cast<int64_t>(steps) * 1'000'000, now);
  return contract::Outcome::done();
}

contract::Outcome ReplayControl::reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  playback_.seek(playback_.start_ns(), now_ns());
  return contract::Outcome::done();
}

contract::Outcome ReplayControl::place(std::size_t, double, double, double) {
  return contract::Outcome::fail(contract::ErrorKind::kConflict, kReplayCannotChangeWorld);
}

contract::Outcome ReplayControl::push(std::size_t, double, double, double, uint32_t) {
  return contract::Outcome::fail(contract::ErrorKind::kConflict, kReplayCannotChangeWorld);
}

contract::Outcome ReplayControl::ball(double, double) { return contract::Outcome::fail(contract::ErrorKind::kConflict, kReplayCannotChangeWorld); }

contract::Scene ReplayControl::scene() {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t position = position_locked();
  const std::optional<std::size_t> index = recording_.scene().at_or_before(position);
  if (index != scene_index_) {
    scene_ = {};
    recording::Scene scene;
    const std::string_view bytes = index ? recording_.scene().bytes(*index) : std::string_view();
    if (index && scene.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
      scene_.sim_time_s = scene.sim_time_s();
      for (const recording::Shape& s : scene.shapes()) {
        contract::SceneShape shape;
        shape.type = intern(s.type());
        shape.kind = intern(s.kind());
        shape.object_id = static_cast<uint16_t>(s.object_id());
        shape.position = {s.position().x(), s.position().y(), s.position().z()};
        shape.quaternion = {s.orientation().x(), s.orientation().y(), s.orientation().z(), s.orientation().w()};
        if (!s.has_orientation()) shape.quaternion = {0.0, 0.0, 0.0, 1.0};
        shape.size = {s.size().x(), s.size().y(), s.size().z()};
        for (std::size_t k = 0; k < 3 && k < s.colour().size(); ++k) shape.colour[k] = static_cast<uint8_t>(s.colour()[k]);
        shape.vertices.assign(s.vertices().begin(), s.vertices().end());
        shape.triangles.assign(s.triangles().begin(), s.triangles().end());
        scene_.shapes.push_back(std::move(shape));
      }
    }
    scene_index_ = index;
  }
  contract::Scene out = scene_;
  // The poses recorded after this scene, when they are for the same shapes (same count).
  const std::optional<std::size_t> poses = recording_.scene_poses().at_or_before(position);
  if (poses && index && recording_.scene_poses().time_ns(*poses) >= recording_.scene().time_ns(*index)) {
    if (poses != poses_index_) {
      const std::string_view bytes = recording_.scene_poses().bytes(*poses);
      if (!poses_.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) poses_.Clear();
      poses_index_ = poses;
    }
    if (static_cast<std::size_t>(poses_.positions_size()) == out.shapes.size() &&
        poses_.orientations_size() == poses_.positions_size()) {
      out.sim_time_s = poses_.sim_time_s();
      for (std::size_t i = 0; i < out.shapes.size(); ++i) {
        const recording::Vector3& p = poses_.positions(static_cast<int>(i));
        const recording::Quaternion& q = poses_.orientations(static_cast<int>(i));
        out.shapes[i].position = {p.x(), p.y(), p.z()};
        out.shapes[i].quaternion = {q.x(), q.y(), q.z(), q.w()};
      }
    }
  }
  return out;
}

std::vector<contract::BusTable> ReplayControl::buses() {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t position = position_locked();
  const std::optional<std::size_t> index = recording_.servos().at_or_before(position);
  if (index != servos_index_) {
    servos_.clear();
    recording::ServoTables tables;
    const std::string_view bytes = index ? recording_.servos().bytes(*index) : std::string_view();
    if (index && tables.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
      for (const recording::ServoTable& t : tables.buses()) {
        contract::BusTable table;
        table.robot = t.robot();
        table.robot_name = t.robot_name();
        table.bus = t.bus();
        table.link = t.link();
        for (const recording::ServoRow& r : t.servos()) {
          table.servos.push_back({static_cast<uint8_t>(r.id()), r.name(), r.model(), r.torque(), r.goal_position(),
                                  r.present_position(), r.present_speed(), r.present_load(), r.temperature(),
                                  r.voltage(), r.error()});
        }
        servos_.push_back(std::move(table));
      }
    }
    servos_index_ = index;
  }
  std::vector<contract::BusTable> out = servos_;
  for (contract::BusTable& table : out) {
    const auto points = recording_.bus_counters().find({static_cast<uint32_t>(table.robot), static_cast<uint32_t>(table.bus)});
    if (points == recording_.bus_counters().end()) continue;
    const auto after = std::upper_bound(points->second.begin(), points->second.end(), position,
                                        [](int64_t t, const CounterPoint& p) { return t < p.time_ns; });
    if (after != points->second.begin()) table.counters = std::prev(after)->counters;
  }
  return out;
}

contract::Result<contract::CameraStill> ReplayControl::camera_still(const std::string& name) {
  const auto track = recording_.cameras().find(name);
  if (track == recording_.cameras().end()) {
    std::string names;
    for (const auto& [camera, t] : recording_.cameras()) names += (names.empty() ? "" : ", ") + camera;
    return contract::Error{contract::ErrorKind::kNotFound,
                           "no camera '" + name + "' in the recording (recorded: " + (names.empty() ? "none" : names) + ")"};
  }
  int64_t position = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    position = position_locked();
  }
  const std::optional<std::size_t> index = track->second.at_or_before(position);
  if (!index) {
    return contract::Error{contract::ErrorKind::kUnavailable, "camera '" + name + "' has no recorded still before this moment"};
  }
  recording::CameraImage image;
  const std::string_view bytes = track->second.bytes(*index);
  if (!image.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()))) {
    return contract::Error{contract::ErrorKind::kUnavailable, "the recorded still of camera '" + name + "' is corrupt"};
  }
  return contract::CameraStill{image.data(), image.sim_time_s()};
}

contract::ReplayStatus ReplayControl::replay() {
  std::lock_guard<std::mutex> lock(mutex_);
  contract::ReplayStatus status;
  const int64_t now = now_ns();
  status.start_s = seconds(playback_.start_ns());
  status.end_s = seconds(playback_.end_ns());
  status.position_s = seconds(playback_.position_ns(now));
  status.speed = playback_.speed();
  status.playing = playback_.playing(now);
  for (const auto& [name, track] : recording_.cameras()) status.cameras.push_back(name);
  return status;
}

contract::Outcome ReplayControl::change_replay(const contract::ReplayChange& change) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int64_t now = now_ns();
  if (change.speed) playback_.set_speed(*change.speed, now);
  if (change.position_s) playback_.seek(static_cast<int64_t>(std::llround(*change.position_s * 1e9)), now);
  if (change.playing) {
    if (*change.playing) playback_.play(now); else playback_.pause(now);
  }
  return contract::Outcome::done();
}

std::optional<std::string> ReplayControl::bus_analysis() {
  std::lock_guard<std::mutex> lock(analysis_mutex_);
  if (!analysis_made_) {
    analysis_made_ = true;
    try {
      analysis_ = bus_analysis_json(recording_.path(), recording_.origin_ns());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "doppel-replay: no bus analysis: %s\n", e.what());
    }
  }
  return analysis_;
}

}  // namespace doppel::replay
