#include "live_robots.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>
#include <thread>

#include "bus/latency_timer_files.h"
#include "bus/link_directory.h"
#include "camera/lens.h"
#include "camera/noise.h"
#include "camera/pixel_format.h"
#include "camera/streaming.h"
#include "camera_feed.h"
#include "gateway/gateway.h"
#include "physics/world.h"
#include "robot_builder.h"
#include "robot_runtime.h"
#include "truth/transport.h"
#include "truth/truth_service.h"
#include "truth/world_model.h"

namespace doppel::gateway {

struct LiveRobots::Plan {
  std::size_t index = 0;
  RobotConfig config;
  physics::RobotPlacement placement;
  std::vector<CameraSetup> cameras;         // with the names they stream under
  std::vector<std::string> camera_fields;   // the request's field each came from
};

// One robot added here and how far it was built (tear_down undoes exactly that).
struct LiveRobots::Live {
  std::size_t index = 0;
  RobotConfig config;
  std::optional<std::size_t> in_world;
  std::unique_ptr<RobotRuntime> runtime;
  bool attached = false;                  // SimController::attach
  bool driven = false;                    // in driven_
  bool shown = false;                     // SimController::show
  std::vector<std::size_t> camera_ids;    // CameraFeed::add
  std::vector<std::size_t> camera_bodies;
  std::vector<std::string> camera_names;  // as streamed
  std::size_t cameras_attached = 0;       // CameraFeed::attach of the first ones
  std::unique_ptr<bus::LatencyTimerFiles> latency;
  std::atomic<bool> stop{false};          // its bus threads
  bool threads = false;
  bool world_model = false;               // TruthService::add_robot
  contract::RobotAdded added;
};

namespace {

using contract::Refusal;

bool finite(double v) { return std::isfinite(v); }

// The file's horizontal field of view of a lens made by pinhole_from_hfov / fisheye_from_hfov.
double hfov_deg_of(const camera::CameraConfig& config) {
  try {
    const camera::Lens lens(config.lens, config.width_px, config.height_px);
    Eigen::Vector3d ray;
    if (lens.unproject(Eigen::Vector2d(config.lens.cx_px + 0.5 * config.width_px, config.lens.cy_px), &ray)) {
      return 2.0 * std::atan2(std::hypot(ray.x(), ray.y()), ray.z()) * 180.0 / M_PI;
    }
  } catch (const std::invalid_argument&) {
  }
  return 120.0;  // robot_config.cpp's default
}

// Applies one camera request to the file's settings of that camera; a refusal names the field.
std::optional<Refusal> apply(const contract::CameraRequest& request, const std::string& field, camera::CameraConfig& config) {
  const double file_hfov_deg = hfov_deg_of(config);
  if (request.width_px) {
    if (*request.width_px < 2 || *request.width_px > 8192 || *request.width_px % 2 != 0) {
      return Refusal{field + ".width_px", "must be even and within [2, 8192], got " + std::to_string(*request.width_px)};
    }
    config.width_px = static_cast<int>(*request.width_px);
  }
  if (request.height_px) {
    if (*request.height_px < 2 || *request.height_px > 8192) {
      return Refusal{field + ".height_px", "must lie within [2, 8192], got " + std::to_string(*request.height_px)};
    }
    config.height_px = static_cast<int>(*request.height_px);
  }
  if (request.fps) {
    if (!(*request.fps > 0.0 && *request.fps <= 1000.0)) {
      return Refusal{field + ".fps", "must lie within (0, 1000], got " + std::to_string(*request.fps)};
    }
    config.fps = *request.fps;
  }
  if (request.format) {
    try {
      config.format = camera::parse_pixel_format(*request.format);
    } catch (const std::invalid_argument& e) {
      return Refusal{field + ".format", e.what()};
    }
  }
  camera::LensModel model = config.lens.model;
  if (request.lens) {
    try {
      model = camera::parse_lens_model(*request.lens);
    } catch (const std::invalid_argument& e) {
      return Refusal{field + ".lens", e.what()};
    }
  }
  if (request.hfov_deg && !(*request.hfov_deg > 0.0 && *request.hfov_deg < 180.0)) {
    return Refusal{field + ".hfov_deg", "must lie within (0, 180), got " + std::to_string(*request.hfov_deg)};
  }
  if (request.width_px || request.height_px || request.lens || request.hfov_deg) {
    const double hfov_deg = request.hfov_deg.value_or(file_hfov_deg);
    try {
      config.lens = model == camera::LensModel::kPinhole
                        ? camera::pinhole_from_hfov(config.width_px, config.height_px, hfov_deg)
                        : camera::fisheye_from_hfov(model, config.width_px, config.height_px, hfov_deg);
    } catch (const std::invalid_argument& e) {
      return Refusal{field + (request.hfov_deg ? ".hfov_deg" : request.lens ? ".lens" : ".width_px"), e.what()};
    }
  }
  if (request.noise_gaussian_sigma) config.noise.gaussian_sigma = *request.noise_gaussian_sigma;
  if (request.noise_salt_pepper_fraction) config.noise.salt_pepper_fraction = *request.noise_salt_pepper_fraction;
  if (request.noise_seed) config.noise.seed = *request.noise_seed;
  const std::string_view bad_noise = camera::invalid_noise_field(config.noise);
  if (bad_noise == "gaussian_sigma") {
    return Refusal{field + ".noise_gaussian_sigma", "must lie within [0, 255]"};
  }
  if (bad_noise == "salt_pepper_fraction") {
    return Refusal{field + ".noise_salt_pepper_fraction", "must lie within [0, 1]"};
  }
  try {
    camera::validate(config);
  } catch (const std::invalid_argument& e) {
    return Refusal{field, e.what()};
  }
  return std::nullopt;
}

}  // namespace

LiveRobots::LiveRobots(Parts parts, std::vector<contract::RobotAdded> started)
    : parts_(parts), started_(std::move(started)) {}

LiveRobots::~LiveRobots() { close(); }

std::variant<LiveRobots::Plan, Refusal> LiveRobots::check(const contract::RobotRequest& request) const {
  Plan plan;
  if (parts_.world == nullptr) {
    return Refusal{"", "this doppel runs without a physics world (--physics none): no robot can be added while it runs"};
  }
  if (parts_.options->lockstep.enabled) {
    return Refusal{"", "this doppel runs in lockstep (--lockstep): its robots are fixed at start (docs/lockstep.md)"};
  }
  if (request.world_model) {
    if (parts_.truth == nullptr) {
      return Refusal{"world_model", "this doppel has no truth transport: start it with --world-model (or --sensor-levels) "
                                    "for world models of robots added while it runs"};
    }
    if (const std::string problem = truth::settings_problem(*request.world_model); !problem.empty()) {
      return Refusal{"world_model", problem};
    }
  }
  if (request.sensor_levels) {
    return Refusal{"sensor_levels", "sensor levels are published for the robots doppel started with (--sensor-levels), "
                                    "not yet for robots added while it runs"};
  }
  if (request.robot.empty() == request.description.empty()) {
    return request.robot.empty() ? Refusal{"robot", "name a robot (robot) or give its description (description)"}
                                 : Refusal{"description", "give either a robot name (robot) or a description, not both"};
  }
  const std::string robot_field = request.robot.empty() ? "description" : "robot";
  try {
    const Options& options = *parts_.options;
    plan.config = request.robot.empty()
                      ? parse_robot(request.description, "description")
                      : load_robot(request.robot, options.buses.robots_dir.empty() ? default_robots_dir() : options.buses.robots_dir);
  } catch (const std::exception& e) {
    return Refusal{robot_field, e.what()};
  }
  if (!plan.config.body) {
    return Refusal{robot_field, "robot '" + plan.config.name +
                                    "' has no figure: a robot added while doppel runs needs a body in the physics world"};
  }
  plan.index = kSimMaxRobots;
  for (std::size_t r = started_.size(); r < kSimMaxRobots; ++r) {
    if (live_[r] == nullptr) {
      plan.index = r;
      break;
    }
  }
  if (plan.index >= kSimMaxRobots) {
    return Refusal{robot_field, "doppel serves at most " + std::to_string(kSimMaxRobots) + " robots; remove one first"};
  }

  plan.placement = kick_off_placement(plan.index);
  if (request.x_m.has_value() != request.y_m.has_value()) {
    return Refusal{request.x_m ? "y_m" : "x_m", "x_m and y_m go together: give both or neither"};
  }
  if (request.x_m) {
    if (!finite(*request.x_m) || std::abs(*request.x_m) > parts_.carpet_half_length_m) {
      return Refusal{"x_m", "must lie on the carpet, within +-" + std::to_string(parts_.carpet_half_length_m) + " m"};
    }
    if (!finite(*request.y_m) || std::abs(*request.y_m) > parts_.carpet_half_width_m) {
      return Refusal{"y_m", "must lie on the carpet, within +-" + std::to_string(parts_.carpet_half_width_m) + " m"};
    }
    plan.placement.position_m = Eigen::Vector3d(*request.x_m, *request.y_m, 0.0);
  }
  if (request.yaw_rad) {
    if (!finite(*request.yaw_rad)) return Refusal{"yaw_rad", "must be a finite angle"};
    plan.placement.yaw_rad = *request.yaw_rad;
  }
  if (request.team) {
    if (*request.team > 1) return Refusal{"team", "must be 0 or 1, got " + std::to_string(*request.team)};
    plan.placement.team = static_cast<uint8_t>(*request.team);
  }

  if (request.cameras_off) {
    if (!request.cameras.empty()) return Refusal{"cameras", "cameras_off asks for no camera: leave cameras empty"};
  } else if (parts_.cameras == nullptr) {
    if (!request.cameras.empty()) return Refusal{"cameras", "this doppel streams no camera (--no-camera)"};
  } else if (request.cameras.empty()) {
    plan.cameras = plan.config.cameras;
    plan.camera_fields.assign(plan.cameras.size(), "cameras");
  } else {
    std::string names;
    for (const CameraSetup& setup : plan.config.cameras) names += (names.empty() ? "" : ", ") + setup.config.name;
    for (std::size_t i = 0; i < request.cameras.size(); ++i) {
      const contract::CameraRequest& wanted = request.cameras[i];
      const std::string field = "cameras[" + std::to_string(i) + "]";
      const auto found = std::find_if(plan.config.cameras.begin(), plan.config.cameras.end(),
                                      [&](const CameraSetup& setup) { return setup.config.name == wanted.name; });
      if (found == plan.config.cameras.end()) {
        return Refusal{field + ".name", "robot '" + plan.config.name + "' has no camera '" + wanted.name + "' (its cameras: " +
                                            (names.empty() ? "none" : names) + ")"};
      }
      for (std::size_t j = 0; j < i; ++j) {
        if (request.cameras[j].name == wanted.name) return Refusal{field + ".name", "camera '" + wanted.name + "' is asked for twice"};
      }
      CameraSetup setup = *found;
      if (auto refusal = apply(wanted, field, setup.config)) return *refusal;
      plan.cameras.push_back(std::move(setup));
      plan.camera_fields.push_back(field);
    }
  }
  if (plan.cameras.size() > kSimMaxCameras) {
    return Refusal{"cameras", "at most " + std::to_string(kSimMaxCameras) + " cameras per robot"};
  }
  plan.cameras = RobotBuilder::cameras(plan.index, std::move(plan.cameras));
  return plan;
}

contract::AddResult LiveRobots::add_robot(const contract::RobotRequest& request) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (closed_) return Refusal{"", "doppel is stopping"};
  auto checked = check(request);
  if (auto* refusal = std::get_if<Refusal>(&checked)) return *refusal;
  Plan& plan = std::get<Plan>(checked);
  auto live = std::make_unique<Live>();
  Live& robot = *live;
  robot.index = plan.index;
  robot.config = std::move(plan.config);
  const std::size_t index = robot.index;

  // Cameras first: a frame that does not fit the iceoryx pools is the likeliest failure.
  for (std::size_t c = 0; c < plan.cameras.size(); ++c) {
    try {
      robot.camera_ids.push_back(parts_.cameras->add(plan.cameras[c], *parts_.options));
      robot.camera_bodies.push_back(plan.cameras[c].body);
      robot.camera_names.push_back(plan.cameras[c].config.name);
    } catch (const std::exception& e) {
      tear_down(robot);
      return Refusal{plan.camera_fields[c], "camera '" + plan.cameras[c].config.name + "': " + e.what()};
    }
  }
  double from_s = 0.0;
  try {
    if (index > 0) parts_.links->subdirectory("robot" + std::to_string(index));
    on_simulation_thread([&] {
      physics::World& world = *parts_.world;
      robot.in_world = world.add_robot(*robot.config.body, plan.placement);
      robot.runtime = RobotBuilder(*parts_.options, &world).runtime(robot.config, index, robot.in_world);
      parts_.controller->attach(index, SimController::Robot{robot.runtime.get(), robot.in_world, robot.config.name, &robot.config});
      robot.attached = true;
      for (; robot.cameras_attached < robot.camera_ids.size(); ++robot.cameras_attached) {
        const std::size_t c = robot.cameras_attached;
        parts_.cameras->attach(robot.camera_ids[c], *robot.in_world, robot.camera_bodies[c], plan.cameras[c].config.fps, &world);
      }
      driven_[index] = robot.runtime.get();
      robot.driven = true;
      from_s = world.time_s();
    });
  } catch (const std::exception& e) {
    tear_down(robot);
    return Refusal{request.robot.empty() ? "description" : "robot", std::string("robot '") + robot.config.name + "': " + e.what()};
  }
  try {
    robot.latency = std::make_unique<bus::LatencyTimerFiles>(std::cerr);
    robot.runtime->add_latency_timer_files(*robot.latency);
    robot.latency->start();
    robot.runtime->start(robot.stop, parts_.options->buses.rt_priority);
    robot.threads = true;
    for (const std::size_t id : robot.camera_ids) parts_.cameras->show(id, from_s);
    parts_.controller->show(index);
    robot.shown = true;
  } catch (const std::exception& e) {
    tear_down(robot);
    return Refusal{"", std::string("robot '") + robot.config.name + "': " + e.what()};
  }
  if (request.world_model) {
    const truth::RobotBinding binding = RobotBuilder::truth_binding(robot.config, *robot.in_world, plan.placement.team);
    if (const std::string problem = parts_.truth->add_robot(index, binding, *request.world_model); !problem.empty()) {
      tear_down(robot);
      return Refusal{"world_model", problem};
    }
    robot.world_model = true;
  }

  RobotBuilder::Topics topics;
  if (robot.world_model) {
    topics.transport = &parts_.truth->transport_options();
    topics.world_model = true;
  }
  robot.added = RobotBuilder::listing(index, robot.config, *robot.runtime, robot.camera_names, topics);
  contract::RobotAdded result = robot.added;
  live_[index] = std::move(live);
  return result;
}

std::optional<Refusal> LiveRobots::remove_robot(uint32_t robot) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (robot < started_.size()) {
    return Refusal{"robot", "robot " + std::to_string(robot) + " ('" + started_[robot].name +
                                "') was started with doppel; only robots added while it runs can be removed"};
  }
  if (robot >= live_.size() || live_[robot] == nullptr) {
    return Refusal{"robot", "there is no robot " + std::to_string(robot)};
  }
  tear_down(*live_[robot]);
  live_[robot].reset();
  return std::nullopt;
}

std::vector<contract::RobotAdded> LiveRobots::robots() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<contract::RobotAdded> out = started_;
  for (const auto& live : live_) {
    if (live != nullptr) out.push_back(live->added);
  }
  return out;
}

void LiveRobots::close() {
  std::lock_guard<std::mutex> lock(mutex_);
  closed_ = true;
  for (auto& live : live_) {
    if (live == nullptr) continue;
    tear_down(*live);
    live.reset();
  }
}

void LiveRobots::tear_down(Live& live) noexcept {
  try {
    if (live.world_model) parts_.truth->remove_robot(live.index);
    live.world_model = false;
    if (live.shown) parts_.controller->hide(live.index);
    live.shown = false;
    for (const std::size_t id : live.camera_ids) parts_.cameras->hide(id);  // the streams and their services go
    // RouDi takes them off its list in its discovery loop: wait for it (bounded), so that the names
    // are free for the next robot as soon as this returns.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    for (const std::string& name : live.camera_names) {
      while (camera::camera_offered(name) && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    }
    if (live.threads) {
      live.stop.store(true);
      live.runtime->join();
      live.threads = false;
    }
    live.latency.reset();  // its files go
    on_simulation_thread([&] {
      if (live.driven) driven_[live.index] = nullptr;
      live.driven = false;
      for (std::size_t c = 0; c < live.cameras_attached; ++c) parts_.cameras->detach(live.camera_ids[c]);
      live.cameras_attached = 0;
      if (live.attached) parts_.controller->detach(live.index);
      live.attached = false;
      if (live.in_world) parts_.world->remove_robot(*live.in_world);
      live.in_world.reset();
    });
    live.runtime.reset();  // its ports close: the links go
    for (const std::size_t id : live.camera_ids) parts_.cameras->release(id);
    live.camera_ids.clear();
  } catch (const std::exception& e) {
    std::cerr << "doppel: removing robot " << live.index << ": " << e.what() << "\n" << std::flush;
  }
}

void LiveRobots::on_simulation_thread(const std::function<void()>& job) {
  if (!simulation_running_.load(std::memory_order_acquire)) {
    job();
    return;
  }
  std::exception_ptr error;
  const std::function<void()> guarded = [&] {
    try {
      job();
    } catch (...) {
      error = std::current_exception();
    }
  };
  job_.store(&guarded, std::memory_order_release);
  while (job_.load(std::memory_order_acquire) != nullptr) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (error) std::rethrow_exception(error);
}

void LiveRobots::run_pending() noexcept {
  const std::function<void()>* job = job_.load(std::memory_order_acquire);
  if (job == nullptr) return;
  (*job)();
  job_.store(nullptr, std::memory_order_release);
}

void LiveRobots::drive(double dt_s) noexcept {
  for (RobotRuntime* runtime : driven_) {
    if (runtime != nullptr) runtime->drive(dt_s);
  }
}

void LiveRobots::sense(int64_t sim_time_ns) noexcept {
  for (RobotRuntime* runtime : driven_) {
    if (runtime != nullptr) runtime->sense(sim_time_ns);
  }
}

std::string LiveRobots::summary() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::ostringstream out;
  for (const auto& live : live_) {
    if (live != nullptr && live->runtime != nullptr) out << live->runtime->summary();
  }
  return out.str();
}

}  // namespace doppel::gateway
