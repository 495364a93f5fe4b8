#include "sim_controller.h"

#include <cmath>
#include <thread>

#include "camera/image_io.h"
#include "camera/lens.h"
#include "fault_board.h"
#include "field_services.h"
#include "robot_names.h"
#include "robot_runtime.h"
#include "truth/truth_service.h"

namespace doppel::gateway {
namespace {

constexpr std::chrono::milliseconds kAnswerTimeout{5000};  // a loaded machine may lag its 1 kHz loop

}  // namespace

void SimController::add_devices(std::size_t r) {
  imus_[r].clear();
  feet_[r].clear();
  cameras_[r].clear();
  joint_names_[r].clear();
  const Robot& robot = robots_[r];
  if (world_ != nullptr && robot.in_world) {
    for (const physics::LinkModel& link : world_->robot(*robot.in_world).links) joint_names_[r].push_back(link.name);
  }
  if (joint_names_[r].size() > kMaxJoints) {
    throw std::invalid_argument("simulation control: robot '" + robot.name + "' has more than " +
                                std::to_string(kMaxJoints) + " links");
  }
  if (world_ == nullptr || !robot.in_world) return;
  const std::size_t w = *robot.in_world;
  const RobotConfig& config = robot.config != nullptr ? *robot.config : robot.runtime->config();
  for (std::size_t b = 0; b < config.buses.size(); ++b) {
    for (const DeviceConfig& device : config.buses[b].devices) {
      const auto bus = static_cast<uint32_t>(b);
      if (const auto imu = world_->find_imu(w, bus, device.id)) imus_[r].push_back({device.name, bus, device.id, *imu});
      if (const auto foot = world_->find_foot(w, bus, device.id)) feet_[r].push_back({device.name, bus, device.id, *foot});
    }
  }
  for (const CameraSetup& setup : config.cameras) {
    Camera camera;
    camera.name = robot_camera_name(r, setup.config.name);  // the name CameraFeed streams it under
    camera.body = setup.body;
    camera.config = setup.config;
    const camera::Lens lens(setup.config.lens, setup.config.width_px, setup.config.height_px);
    const double right = setup.config.width_px - 1.0, bottom = setup.config.height_px - 1.0;
    const std::array<Eigen::Vector2d, 4> corners{Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(right, 0.0),
                                                 Eigen::Vector2d(right, bottom), Eigen::Vector2d(0.0, bottom)};
    const Eigen::Vector2d centre(0.5 * right, 0.5 * bottom);
    for (std::size_t c = 0; c < 4; ++c) {
      // A fisheye whose image circle ends inside the image has no ray at its corners: the ray
      // where the corner's diagonal leaves the circle stands in for it.
      Eigen::Vector3d ray;
      for (double t = 1.0; t > 0.0; t -= 0.01) {
        if (lens.unproject(centre + t * (corners[c] - centre), &ray)) break;
      }
      camera.corner_rays[c] = {ray.x(), ray.y(), ray.z()};
    }
    cameras_[r].push_back(std::move(camera));
  }
  if (imus_[r].size() > kSimMaxImus || feet_[r].size() > kSimMaxFeet || cameras_[r].size() > kSimMaxCameras) {
    throw std::invalid_argument("simulation control: robot '" + robot.name + "' has more than " +
                                std::to_string(kSimMaxImus) + " IMUs, " + std::to_string(kSimMaxFeet) +
                                " foot boards or " + std::to_string(kSimMaxCameras) + " cameras");
  }
}

SimController::SimController(physics::World* world, std::vector<Robot> robots, double carpet_half_length_m,
                             double carpet_half_width_m)
    : world_(world),
      robots_(std::move(robots)),
      carpet_half_length_m_(carpet_half_length_m),
      carpet_half_width_m_(carpet_half_width_m) {
  if (robots_.size() > kMaxRobots) {
    throw std::invalid_argument("simulation control: at most " + std::to_string(kMaxRobots) + " robots");
  }
  const std::size_t count = robots_.size();
  robots_.resize(kMaxRobots);  // every slot now: robots added later never move the others
  joint_names_.resize(kMaxRobots);
  imus_.resize(kMaxRobots);
  feet_.resize(kMaxRobots);
  cameras_.resize(kMaxRobots);
  for (std::size_t r = 0; r < count; ++r) {
    add_devices(r);
    present_[r] = shown_[r] = true;
  }
  if (world_ != nullptr) {
    ScenePublication initial;
    world_->fill_scene(initial.view);  // sizes the shapes once: later fills of a copy do not allocate
    for (auto& robot : initial.X_WC) robot.fill(Eigen::Isometry3d::Identity());
    scene_ = std::make_unique<concurrency::Snapshot<ScenePublication>>(initial);
    for (std::size_t r = 0; r < cameras_.size(); ++r) {
      for (std::size_t i = 0; i < cameras_[r].size(); ++i) {
        stills_.emplace_back();
        stills_.back().robot = r;
        stills_.back().camera = i;
      }
    }
  }
  // The start, for a request that comes before the first tick (the simulation thread is not
  // running yet: publishing from here is the writer's first publish).
  publish_sample(world_ != nullptr ? world_->time_ns() : 0, 0);
}

namespace {

const char* shape_type(physics::ShapeType type) {
  switch (type) {
    case physics::ShapeType::kBox: return "box";
    case physics::ShapeType::kSphere: return "sphere";
    case physics::ShapeType::kCylinder: return "cylinder";
    case physics::ShapeType::kCapsule: return "capsule";
    case physics::ShapeType::kRing: return "ring";
    case physics::ShapeType::kConvex: return "convex";
  }
  return "box";
}

const char* object_kind(physics::ObjectKind kind) {
  switch (kind) {
    case physics::ObjectKind::kCarpet: return "carpet";
    case physics::ObjectKind::kFieldLine: return "line";
    case physics::ObjectKind::kGoalPost: return "goal_post";
    case physics::ObjectKind::kGoalBar: return "goal_bar";
    case physics::ObjectKind::kGoalNet: return "goal_net";
    case physics::ObjectKind::kBall: return "ball";
    case physics::ObjectKind::kSidePole: return "side_pole";
    case physics::ObjectKind::kRobotBody: return "robot";
    case physics::ObjectKind::kTeamMarker: return "team_marker";
    case physics::ObjectKind::kOther: return "other";
  }
  return "other";
}

}  // namespace

contract::Scene SimController::scene() {
  contract::Scene out;
  if (scene_ == nullptr) return out;
  physics::SceneView view;
  {
    std::lock_guard<std::mutex> lock(scene_mutex_);
    view = scene_->latest().view;  // copies (allocates) on this HTTP thread, never on the simulation's
  }
  out.sim_time_s = view.sim_time_s;
  out.shapes.reserve(view.shapes.size());
  for (const physics::VisualShape& shape : view.shapes) {
    contract::SceneShape s;
    s.type = shape_type(shape.type);
    s.kind = object_kind(shape.kind);
    s.object_id = shape.object_id;
    const Eigen::Vector3d p = shape.X_WS.translation();
    const Eigen::Quaterniond q(shape.X_WS.linear());
    s.position = {p.x(), p.y(), p.z()};
    s.quaternion = {q.x(), q.y(), q.z(), q.w()};
    const double scale = shape.type == physics::ShapeType::kConvex ? 2.0 : 1.0;  // half extents -> box size
    s.size = {scale * shape.size_m.x(), scale * shape.size_m.y(), scale * shape.size_m.z()};
    s.colour = {shape.colour.r, shape.colour.g, shape.colour.b};
    if (shape.type == physics::ShapeType::kConvex && shape.hull != nullptr) {
      const physics::ConvexHull& hull = *shape.hull;
      for (const Eigen::Vector3d& v : hull.vertices) s.vertices.insert(s.vertices.end(), {v.x(), v.y(), v.z()});
      std::size_t at = 0;  // polygons: count, then indices; each face fanned into triangles
      for (std::size_t f = 0; f < hull.face_count && at < hull.polygons.size(); ++f) {
        const unsigned n = hull.polygons[at];
        for (unsigned k = 2; k < n; ++k) {
          s.triangles.insert(s.triangles.end(), {hull.polygons[at + 1], hull.polygons[at + k], hull.polygons[at + k + 1]});
        }
        at += n + 1;
      }
    }
    out.shapes.push_back(std::move(s));
  }
  return out;
}

Eigen::Isometry3d SimController::camera_pose(std::size_t r, std::size_t i) const noexcept {
  const Camera& camera = cameras_[r][i];
  return camera::camera_pose_W(camera.config.mount, world_->body_pose(*robots_[r].in_world, camera.body));
}

contract::Result<contract::CameraStill> SimController::camera_still(const std::string& name) {
  std::lock_guard<std::mutex> lock(stills_mutex_);  // HTTP threads only: one still rendered at a time
  Still* still = nullptr;
  for (Still& s : stills_) {
    if (cameras_[s.robot][s.camera].name == name) still = &s;
  }
  if (still == nullptr) {
    std::string names;
    for (const Still& s : stills_) names += (names.empty() ? "" : ", ") + cameras_[s.robot][s.camera].name;
    return contract::Error{contract::ErrorKind::kNotFound, "no camera '" + name + "' (robot cameras: " + (names.empty() ? "none" : names) + ")"};
  }
  const auto now = std::chrono::steady_clock::now();
  if (!still->png.empty() && now - still->taken < kStillPeriod) return contract::CameraStill{still->png, still->sim_time_s};
  ScenePublication publication;
  {
    std::lock_guard<std::mutex> scene_lock(scene_mutex_);
    publication = scene_->latest();  // a copy on this thread; the simulation thread never waits
  }
  if (!still->png.empty() && publication.view.sim_time_s == still->sim_time_s) {
    still->taken = now;  // paused: the same scene, the same picture
    return contract::CameraStill{still->png, still->sim_time_s};
  }
  const camera::CameraConfig& config = cameras_[still->robot][still->camera].config;
  if (still->renderer == nullptr) {
    still->renderer = std::make_unique<camera::Renderer>(config.lens, config.width_px, config.height_px,
                                                         camera::PixelFormat::kRgb24);
    still->renderer->set_noise(config.noise);
    still->rgb.resize(3 * static_cast<std::size_t>(config.width_px) * static_cast<std::size_t>(config.height_px));
  }
  const auto frame = static_cast<uint64_t>(publication.view.sim_time_s * 1000.0);  // keys the noise
  still->renderer->render(publication.view, publication.X_WC[still->robot][still->camera], frame, still->rgb.data(), nullptr);
  still->png = camera::encode_png_rgb(still->rgb.data(), config.width_px, config.height_px);
  still->sim_time_s = publication.view.sim_time_s;
  still->taken = now;
  return contract::CameraStill{still->png, still->sim_time_s};
}

std::vector<contract::BusTable> SimController::buses() {
  std::vector<contract::BusTable> out;
  std::lock_guard<std::mutex> lock(robots_mutex_);
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!shown_[r]) continue;
    for (contract::BusTable& table : robots_[r].runtime->servo_tables()) {
      table.robot = r;
      table.robot_name = robots_[r].name;
      out.push_back(std::move(table));
    }
  }
  return out;
}

// The queue behind keep_published_states(): the simulation thread pushes each published sample,
// the reader converts it on its own thread.
class SimController::KeptStates final : public contract::StateQueue {
 public:
  explicit KeptStates(SimController& controller) : controller_(controller) {}
  bool pop(contract::SimState& out) override {
    if (!samples_.try_pop(sample_)) return false;
    out = controller_.state_of(sample_);
    return true;
  }
  uint64_t lost() const override { return samples_.dropped(); }
  void push(const Sample& sample) noexcept { samples_.try_push(sample); }

 private:
  SimController& controller_;
  concurrency::SpscQueue<Sample, kKeptStates> samples_;
  Sample sample_;  // the reader's copy
};

SimController::~SimController() = default;

contract::StateQueue* SimController::keep_published_states() {
  if (kept_ == nullptr) kept_ = std::make_unique<KeptStates>(*this);
  return kept_.get();
}

contract::SimState SimController::state() {
  Sample sample;
  {
    std::lock_guard<std::mutex> lock(read_mutex_);
    samples_.read(sample);
  }
  return state_of(sample);
}

contract::SimState SimController::state_of(const Sample& sample) {
  contract::SimState state;
  state.sim_time_s = static_cast<double>(sample.sim_time_ns) * 1e-9;
  state.paused = sample.paused;
  state.steps_left = sample.steps_left;
  state.missed_ticks = sample.missed_ticks;
  state.carpet_half_length_m = carpet_half_length_m_;
  state.carpet_half_width_m = carpet_half_width_m_;
  std::lock_guard<std::mutex> lock(robots_mutex_);
  std::size_t count = 0;  // up to the last robot shown; an empty slot before it is a robot without a name
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (shown_[r]) count = r + 1;
  }
  for (std::size_t r = 0; r < count; ++r) {
    const RobotSample& s = sample.robots[r];
    contract::RobotState robot;
    if (!shown_[r]) {
      state.robots.push_back(std::move(robot));
      continue;
    }
    robot.name = robots_[r].name;
    robot.simulated = world_ != nullptr && robots_[r].in_world.has_value();
    if (robot.simulated) {
      robot.x_m = s.x;
      robot.y_m = s.y;
      robot.z_m = s.z;
      robot.yaw_rad = s.yaw;
      robot.tilt_rad = s.tilt;
      robot.fallen = s.tilt > contract::kFallenTiltRad;
      robot.held = s.held;
      for (std::size_t j = 0; j < joint_names_[r].size(); ++j) robot.joints.push_back({joint_names_[r][j], s.joints[j]});
      for (std::size_t i = 0; i < imus_[r].size(); ++i) {
        const auto& imu = imus_[r][i];
        robot.imus.push_back({imu.name, imu.bus, imu.id, s.imus[i].roll, s.imus[i].pitch, s.imus[i].gyro});
      }
      for (std::size_t i = 0; i < feet_[r].size(); ++i) {
        const auto& foot = feet_[r][i];
        robot.feet.push_back({foot.name, foot.bus, foot.id, s.feet[i]});
      }
      for (std::size_t i = 0; i < cameras_[r].size(); ++i) {
        robot.cameras.push_back({cameras_[r][i].name, s.cameras[i].p, s.cameras[i].q, cameras_[r][i].corner_rays});
      }
    }
    state.robots.push_back(std::move(robot));
  }
  if (world_ != nullptr && world_->options().ball.present) {
    state.ball_m = std::vector<double>(sample.ball.begin(), sample.ball.end());
  }
  return state;
}

contract::Outcome SimController::submit(Request request, std::chrono::milliseconds timeout) {
  std::lock_guard<std::mutex> lock(submit_mutex_);
  request.sequence = ++next_sequence_;
  if (!requests_.try_push(request)) {
    return contract::Outcome::fail(contract::ErrorKind::kUnavailable, "the simulation has not taken the previous requests yet; try again");
  }
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (finished_.load(std::memory_order_acquire) < request.sequence) {
    if (std::chrono::steady_clock::now() > deadline) {
      return contract::Outcome::fail(contract::ErrorKind::kUnavailable, "the simulation thread did not carry the request out within " +
                                             std::to_string(timeout.count()) + " ms (it is applied when it gets to it)");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (finished_refused_.load(std::memory_order_acquire)) {
    return contract::Outcome::fail(contract::ErrorKind::kConflict, "step needs a paused simulation: pause first");
  }
  return contract::Outcome::done();
}

contract::Outcome SimController::pause() { return submit({Kind::kPause}, kAnswerTimeout); }

contract::Outcome SimController::resume() { return submit({Kind::kResume}, kAnswerTimeout); }

contract::Outcome SimController::step(uint32_t steps) {
  Request request{Kind::kStep};
  request.steps = steps;
  return submit(request, kAnswerTimeout + std::chrono::milliseconds(2 * static_cast<int64_t>(steps)));
}

contract::Outcome SimController::reset() { return submit({Kind::kReset}, kAnswerTimeout); }

contract::Outcome SimController::place(std::size_t robot, double x_m, double y_m, double yaw_rad) {
  return submit({Kind::kPlace, 0, robot, x_m, y_m, yaw_rad}, kAnswerTimeout);
}

contract::Outcome SimController::push(std::size_t robot, double fx_n, double fy_n, double fz_n, uint32_t steps) {
  return submit({Kind::kPush, 0, robot, fx_n, fy_n, fz_n, steps}, kAnswerTimeout);
}

contract::Outcome SimController::ball(double x_m, double y_m) {
  return submit({Kind::kBall, 0, 0, x_m, y_m}, kAnswerTimeout);
}

contract::Result<contract::WorldModelSettings> SimController::world_model(std::size_t robot) {
  const std::optional<contract::WorldModelSettings> settings = truth_->settings(robot);
  if (!settings) {
    return contract::Error{contract::ErrorKind::kNotFound, "robot " + std::to_string(robot) + " has no world-model sensor (no body in the world)"};
  }
  return *settings;
}

contract::Result<contract::WorldModelSettings> SimController::set_world_model(std::size_t robot,
                                                                              const contract::WorldModelSettings& settings) {
  const contract::Result<contract::WorldModelSettings> now = world_model(robot);
  if (!now.ok()) return now;
  if (const std::string problem = truth_->set_settings(robot, settings); !problem.empty()) {
    return contract::Error{contract::ErrorKind::kInvalid, problem};
  }
  return settings;
}

void SimController::finish(uint64_t sequence, bool refused) noexcept {
  finished_refused_.store(refused, std::memory_order_release);
  finished_.store(sequence, std::memory_order_release);
}

void SimController::apply(const Request& request) noexcept {
  const bool has_body = request.robot < robots_.size() && present_[request.robot] && world_ != nullptr &&
                        robots_[request.robot].in_world.has_value();
  const std::size_t body = has_body ? *robots_[request.robot].in_world : 0;
  bool refused = false;
  switch (request.kind) {
    case Kind::kPause:
      paused_ = true;
      break;
    case Kind::kResume:
      paused_ = false;
      break;
    case Kind::kStep:
      if (!paused_) {
        refused = true;
        break;
      }
      steps_left_ = request.steps;
      step_sequence_ = request.sequence;
      return;  // finished when the steps ran (end_tick)
    case Kind::kReset:
      for (std::size_t r = 0; r < robots_.size(); ++r) {
        if (!present_[r]) continue;
        const Robot& robot = robots_[r];
        if (world_ != nullptr && robot.in_world) world_->reset_robot(*robot.in_world);
        robot.runtime->power_on();
      }
      if (world_ != nullptr) world_->reset_ball();
      break;
    case Kind::kPlace:
      if (has_body) world_->place_robot(body, request.a, request.b, request.c);
      break;
    case Kind::kPush:
      if (has_body) world_->push(body, Eigen::Vector3d(request.a, request.b, request.c), request.steps);
      break;
    case Kind::kBall:
      if (world_ != nullptr) {
        world_->place_ball(Eigen::Vector3d(request.a, request.b, world_->options().ball.radius_m), Eigen::Vector3d::Zero());
      }
      break;
  }
  pending_sequence_ = request.sequence;
  pending_refused_ = refused;
}

bool SimController::begin_tick() noexcept {
  Request request;
  while (requests_.try_pop(request)) apply(request);
  advancing_ = steps_left_ > 0 || !paused_;
  return advancing_;
}

void SimController::publish_sample(int64_t sim_time_ns, uint64_t missed_ticks) noexcept {
  Sample& sample = samples_.back();
  sample.sim_time_ns = sim_time_ns;
  sample.paused = paused_;
  sample.steps_left = steps_left_;
  sample.missed_ticks = missed_ticks;
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    if (!present_[r] || world_ == nullptr || !robots_[r].in_world) continue;
    const std::size_t w = *robots_[r].in_world;
    RobotSample& s = sample.robots[r];
    const Eigen::Isometry3d X_WR = world_->robot_pose(w);
    s.x = X_WR.translation().x();
    s.y = X_WR.translation().y();
    s.z = X_WR.translation().z();
    s.yaw = std::atan2(X_WR.linear()(1, 0), X_WR.linear()(0, 0));
    s.tilt = world_->tilt_rad(w);
    s.held = world_->held(w);
    for (std::size_t j = 0; j < joint_names_[r].size(); ++j) s.joints[j] = world_->link_position(w, j);
    for (std::size_t i = 0; i < imus_[r].size(); ++i) {
      const physics::ImuState imu = world_->imu(imus_[r][i].handle);  // what the device reports
      s.imus[i] = {imu.roll_rad, imu.pitch_rad, imu.w_WS_S_rad_s};
    }
    for (std::size_t i = 0; i < feet_[r].size(); ++i) s.feet[i] = world_->foot(feet_[r][i].handle).force_n;
    for (std::size_t i = 0; i < cameras_[r].size(); ++i) {
      const Eigen::Isometry3d X_WC = camera_pose(r, i);
      const Eigen::Quaterniond q(X_WC.linear());
      s.cameras[i].p = {X_WC.translation().x(), X_WC.translation().y(), X_WC.translation().z()};
      s.cameras[i].q = {q.x(), q.y(), q.z(), q.w()};
    }
  }
  if (world_ != nullptr) {
    const Eigen::Vector3d ball = world_->ball_position();
    sample.ball = {ball.x(), ball.y(), ball.z()};
  }
  if (kept_ != nullptr) kept_->push(sample);
  samples_.publish();
}

void SimController::end_tick(int64_t sim_time_ns, uint64_t missed_ticks) noexcept {
  bool step_done = false;
  if (advancing_ && steps_left_ > 0) {
    step_done = --steps_left_ == 0;
  }
  const bool answer_due = pending_sequence_ != 0 || step_done;
  if (++ticks_ >= kPublishEveryTicks || answer_due) {
    ticks_ = 0;
    publish_sample(sim_time_ns, missed_ticks);
  }
  if (scene_ != nullptr && ++scene_ticks_ >= kSceneEveryTicks) {
    scene_ticks_ = 0;
    ScenePublication& publication = scene_->back();
    world_->fill_scene(publication.view);  // same shape count as at setup: no allocation (after a
                                           // robot was added, each slot grows once)
    publication.view.sim_time_s = static_cast<double>(sim_time_ns) * 1e-9;
    for (std::size_t r = 0; r < cameras_.size(); ++r) {
      if (!present_[r]) continue;
      for (std::size_t i = 0; i < cameras_[r].size(); ++i) publication.X_WC[r][i] = camera_pose(r, i);
    }
    scene_->publish();
  }
  if (pending_sequence_ != 0) {
    finish(pending_sequence_, pending_refused_);
    pending_sequence_ = 0;
  }
  if (step_done) finish(step_sequence_, false);
}

contract::GameStatus SimController::game() {
  return field_->game_status();
}

contract::Outcome SimController::game_command(const contract::GameCommand& command) {
  return field_->game_command(command);
}

std::optional<contract::TeamcommStatus> SimController::teamcomm() {
  return field_->teamcomm_status();
}

contract::Outcome SimController::teamcomm_add(const contract::TeamcommRobot& robot) {
  return field_->teamcomm_add(robot);
}

contract::FaultList SimController::faults() {
  return faults_->list();
}

contract::Result<uint32_t> SimController::add_fault(const faults::FaultSpec& spec) {
  return faults_->add(spec);
}

contract::Outcome SimController::clear_fault(uint32_t number) {
  return faults_->clear(number);
}

contract::Outcome SimController::clear_faults() {
  return faults_->clear_all();
}

contract::Outcome SimController::teamcomm_remove(int team, int player) {
  return field_->teamcomm_remove(team, player);
}

contract::Facets SimController::facets() noexcept {
  contract::Facets facets;
  facets.simulation = this;
  if (truth_ != nullptr) facets.world_model = this;
  if (field_ != nullptr) {
    facets.game = this;
    facets.teamcomm = this;
  }
  if (faults_ != nullptr) facets.faults = this;
  return facets;
}

void SimController::attach(std::size_t index, Robot robot) {
  if (index >= kMaxRobots || present_[index]) {
    throw std::invalid_argument("simulation control: robot slot " + std::to_string(index) + " is not free");
  }
  robots_[index] = std::move(robot);
  try {
    add_devices(index);
  } catch (...) {
    detach(index);
    throw;
  }
  present_[index] = true;
}

void SimController::show(std::size_t index) {
  {
    std::lock_guard<std::mutex> lock(stills_mutex_);
    for (std::size_t i = 0; world_ != nullptr && i < cameras_[index].size(); ++i) {
      stills_.emplace_back();
      stills_.back().robot = index;
      stills_.back().camera = i;
    }
  }
  std::lock_guard<std::mutex> lock(robots_mutex_);
  shown_[index] = true;
}

void SimController::hide(std::size_t index) {
  {
    std::lock_guard<std::mutex> lock(robots_mutex_);
    shown_[index] = false;
  }
  std::lock_guard<std::mutex> lock(stills_mutex_);
  std::erase_if(stills_, [&](const Still& still) { return still.robot == index; });
}

void SimController::detach(std::size_t index) noexcept {
  present_[index] = false;
  robots_[index] = Robot{};
  joint_names_[index].clear();
  imus_[index].clear();
  feet_[index].clear();
  cameras_[index].clear();
}

}  // namespace doppel::gateway
