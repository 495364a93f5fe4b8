// doppel-truth: prints or saves a robot's world-model or sensor-levels messages (docs/multilevel.md),
// read over iceoryx from a doppel on this machine (doppel --world-model, --sensor-levels) or from a
// UDP port.
#include <google/protobuf/util/json_util.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>

#include "base/command_line.h"
#include "camera/client.h"
#include "proto/sensor_levels.pb.h"
#include "proto/truth.pb.h"
#include "truth/subscriber.h"
#include "truth/truth_service.h"

namespace {

using doppel::proto::truth::WorldModel;
using doppel::levels::SensorLevels;

// doppel --sensor-levels publishes on this topic (services/gateway/src/sensor_levels_feed.h).
constexpr const char kSensorLevelsTopic[] = "sensor_levels";

std::string fixed(double x, int digits = 3) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*f", digits, x);
  return text;
}

std::string degrees(double rad) { return fixed(rad * 180.0 / std::numbers::pi, 1); }

// One line: time, own pose, each ball with distance and bearing, how many of the other objects.
std::string line(const WorldModel& m) {
  std::ostringstream out;
  out << "robot " << m.robot() << " #" << m.sequence() << " t " << fixed(static_cast<double>(m.sim_time_ns()) * 1e-9)
      << " s";
  if (m.world_time_ns() != m.sim_time_ns()) out << " (world at " << fixed(static_cast<double>(m.world_time_ns()) * 1e-9) << " s)";
  out << " pose " << fixed(m.pose().x_m()) << " " << fixed(m.pose().y_m()) << " " << degrees(m.pose().yaw_rad()) << " deg";
  out << " | balls";
  if (m.balls_size() == 0) out << " none";
  for (const auto& ball : m.balls()) {
    out << " [" << ball.index() << "] " << fixed(ball.field().x_m()) << " " << fixed(ball.field().y_m()) << " at "
        << fixed(ball.relative().distance_m()) << " m " << degrees(ball.relative().bearing_rad()) << " deg";
  }
  out << " | posts " << m.goal_posts_size() << ", poles " << m.side_poles_size() << ", landmarks " << m.landmarks_size()
      << ", robots " << m.robots_size();
  return out.str();
}

// One line: time; the servos' largest difference between decoded and true angle; each IMU's
// decoded and true specific force; the feet's decoded and true total force.
std::string line(const SensorLevels& m) {
  std::ostringstream out;
  out << "robot " << m.robot() << " #" << m.sequence() << " t " << fixed(static_cast<double>(m.sim_time_ns()) * 1e-9)
      << " s | " << m.servos_size() << " servos";
  const doppel::levels::ServoLevels* worst = nullptr;
  for (const auto& s : m.servos()) {
    const double error = std::fabs(s.decoded().present_position_rad() - s.truth().angle_rad());
    if (worst == nullptr || error > std::fabs(worst->decoded().present_position_rad() - worst->truth().angle_rad())) worst = &s;
  }
  if (worst != nullptr) {
    out << ", largest |decoded - true| " << fixed(std::fabs(worst->decoded().present_position_rad() - worst->truth().angle_rad()) *
                                                  180.0 / std::numbers::pi, 3)
        << " deg (ID " << worst->id() << ")";
  }
  for (const auto& imu : m.imus()) {
    const auto& d = imu.decoded().accel_m_s2();
    const auto& t = imu.truth().specific_force_m_s2();
    out << " | IMU " << imu.id() << " accel " << fixed(d.x(), 2) << " " << fixed(d.y(), 2) << " " << fixed(d.z(), 2)
        << " (true " << fixed(t.x(), 2) << " " << fixed(t.y(), 2) << " " << fixed(t.z(), 2) << ") m/s^2";
  }
  if (m.feet_size() > 0) {
    double decoded = 0.0, truth = 0.0;
    for (const auto& foot : m.feet()) {
      for (double f : foot.decoded_force_n()) decoded += f;
      for (double f : foot.true_force_n()) truth += f;
    }
    out << " | feet " << fixed(decoded, 2) << " N (true " << fixed(truth, 2) << " N)";
  }
  return out.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("doppel-truth: a robot's world-model or sensor-levels messages from a running doppel (doppel --world-model, "
               "--sensor-levels)", "doppel-truth");
  std::string topic = doppel::truth::kWorldModelTopic;
  std::size_t robot = 0;
  bool robot_given = false;
  uint64_t count = 0;
  bool json = false;
  std::optional<uint16_t> udp_port;
  std::string udp_address = "127.0.0.1";
  std::string out_path;
  double timeout_s = 10.0;
  app.add_option_function<std::size_t>("--robot", [&](std::size_t r) { robot = r; robot_given = true; },
                                       "the robot's index (default 0)")
      ->transform(doppel::number_in<std::size_t>(0, doppel::truth::kMaxRobots - 1));
  app.add_option("--count", count, "stop after K messages (default: until interrupted)")
      ->transform(doppel::number_in<uint64_t>(1, 1'000'000'000));
  app.add_option("--topic", topic, "world_model (doppel --world-model) or sensor_levels (doppel --sensor-levels)")
      ->capture_default_str()
      ->check(CLI::IsMember({doppel::truth::kWorldModelTopic, kSensorLevelsTopic}));
  app.add_flag("--json", json, "one JSON object per line (protobuf's JSON mapping, field names as in libs/proto/truth.proto)");
  app.add_option("--udp", udp_port, "receive on this UDP port instead of iceoryx (robot N's port is doppel's "
                                    "--truth-udp-port base + N)")
      ->transform(doppel::number_in<uint16_t>(1, 65535));
  app.add_option("--udp-address", udp_address, "the address to receive on with --udp")->capture_default_str();
  app.add_option("--out", out_path, "write the lines to FILE instead of stdout");
  app.add_option("--timeout", timeout_s, "give up when no message came for this long (s)")
      ->capture_default_str()
      ->transform(doppel::number_in<double>(0.1, 3600.0));
  CLI11_PARSE(app, argc, argv);

  std::ofstream file;
  if (!out_path.empty()) {
    file.open(out_path, std::ios::trunc);
    if (!file) {
      std::fprintf(stderr, "doppel-truth: cannot write %s\n", out_path.c_str());
      return 2;
    }
  }
  std::ostream& out = out_path.empty() ? std::cout : file;
  try {
    std::optional<doppel::truth::UdpReceiver> udp;
    std::optional<doppel::truth::IceoryxSubscriber> iceoryx;
    if (udp_port) {
      udp.emplace(*udp_port, udp_address);
    } else {
      doppel::camera::connect_client("doppel-truth");
      iceoryx.emplace(robot, topic);
    }
    google::protobuf::util::JsonPrintOptions json_options;
    json_options.preserve_proto_field_names = true;
    json_options.always_print_primitive_fields = true;
    for (uint64_t received = 0; count == 0 || received < count;) {
      std::optional<std::string> bytes;
      if (udp) {
        std::optional<doppel::truth::Datagram> datagram = udp->receive(timeout_s);
        if (datagram && (datagram->topic != topic || (robot_given && datagram->robot != robot))) {
          continue;
        }
        if (datagram) bytes = std::move(datagram->payload);
      } else {
        bytes = iceoryx->take(timeout_s);
      }
      if (!bytes) {
        std::fprintf(stderr, "doppel-truth: no %s message for %g s (is doppel running with --%s?)\n", topic.c_str(),
                     timeout_s, topic == kSensorLevelsTopic ? "sensor-levels HZ" : "world-model");
        return 1;
      }
      auto print = [&](auto& message) {
        if (!message.ParseFromString(*bytes)) {
          std::fprintf(stderr, "doppel-truth: a message that is not a %s (%zu bytes) skipped\n",
                       message.GetDescriptor()->name().c_str(), bytes->size());
          return false;
        }
        if (json) {
          std::string text;
          (void)google::protobuf::util::MessageToJsonString(message, &text, json_options);
          out << text << "\n";
        } else {
          out << line(message) << "\n";
        }
        return true;
      };
      WorldModel world_model;
      SensorLevels sensor_levels;
      if (!(topic == kSensorLevelsTopic ? print(sensor_levels) : print(world_model))) continue;
      out.flush();
      ++received;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "doppel-truth: %s\n", e.what());
    return 2;
  }
  return 0;
}
