// doppel-truth: prints or saves a robot's world-model messages (docs/multilevel.md), read over
// iceoryx from a doppel on this machine (doppel --world-model) or from a UDP port.
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
#include "proto/truth.pb.h"
#include "truth/subscriber.h"
#include "truth/truth_service.h"

namespace {

using doppel::proto::truth::WorldModel;

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

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("doppel-truth: a robot's world-model messages from a running doppel (doppel --world-model)", "doppel-truth");
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
  app.add_flag("--json", json, "one JSON object per line (protobuf's JSON mapping, field names as in proto/truth.proto)");
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
      iceoryx.emplace(robot, doppel::truth::kWorldModelTopic);
    }
    google::protobuf::util::JsonPrintOptions json_options;
    json_options.preserve_proto_field_names = true;
    json_options.always_print_primitive_fields = true;
    for (uint64_t received = 0; count == 0 || received < count;) {
      std::optional<std::string> bytes;
      if (udp) {
        std::optional<doppel::truth::Datagram> datagram = udp->receive(timeout_s);
        if (datagram && (datagram->topic != doppel::truth::kWorldModelTopic || (robot_given && datagram->robot != robot))) {
          continue;
        }
        if (datagram) bytes = std::move(datagram->payload);
      } else {
        bytes = iceoryx->take(timeout_s);
      }
      if (!bytes) {
        std::fprintf(stderr, "doppel-truth: no world-model message for %g s (is doppel running with --world-model?)\n", timeout_s);
        return 1;
      }
      WorldModel message;
      if (!message.ParseFromString(*bytes)) {
        std::fprintf(stderr, "doppel-truth: a message that is not a WorldModel (%zu bytes) skipped\n", bytes->size());
        continue;
      }
      if (json) {
        std::string text;
        (void)google::protobuf::util::MessageToJsonString(message, &text, json_options);
        out << text << "\n";
      } else {
        out << line(message) << "\n";
      }
      out.flush();
      ++received;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "doppel-truth: %s\n", e.what());
    return 2;
  }
  return 0;
}
