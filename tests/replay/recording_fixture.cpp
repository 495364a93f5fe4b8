#include "recording_fixture.h"

#include <google/protobuf/descriptor.pb.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "mcap/mcap.h"
#include "proto/recording.pb.h"

namespace doppel::testing {
namespace {

std::string descriptor_set() {
  google::protobuf::FileDescriptorSet set;
  recording::WorldState::descriptor()->file()->CopyTo(set.add_file());
  return set.SerializeAsString();
}

recording::Quaternion about_y(double angle_rad) {
  recording::Quaternion q;
  q.set_y(std::sin(angle_rad / 2));
  q.set_w(std::cos(angle_rad / 2));
  return q;
}

}  // namespace

void write_recording_fixture(const std::string& path, const RecordingFixture& f) {
  mcap::WriterOptions options;
  options.compression = f.zstd ? mcap::Compression::kZstd : mcap::Compression::kNone;
  mcap::Writer writer(path, options);
  const std::string schema_data = descriptor_set();
  std::map<std::string, uint16_t> channels;
  auto channel = [&](const std::string& topic, const std::string& type) {
    auto found = channels.find(topic);
    if (found != channels.end()) return found->second;
    const uint16_t schema = writer.add_schema("doppel.recording." + type, "protobuf", schema_data);
    return channels[topic] = writer.add_channel(schema, topic, "protobuf");
  };
  // Messages are gathered first and written in log-time order, as the recorder's one queue does.
  struct Pending {
    int64_t t_ns;
    uint16_t channel;
    std::string bytes;
  };
  std::vector<Pending> messages;
  auto add = [&](int64_t t_ns, const std::string& topic, const std::string& type, const google::protobuf::Message& m) {
    messages.push_back({t_ns, channel(topic, type), m.SerializeAsString()});
  };
  const int64_t end_ns = static_cast<int64_t>(f.seconds * 1e9);

  recording::RunInfo run;
  run.set_doppel_version("test");
  run.set_command_line("doppel --record fixture.mcap");
  run.set_start_monotonic_ns(kFixtureOriginNs);
  run.set_physics_engine("ode");
  run.set_timing_mode("fast");
  recording::BusInfo* bus = run.add_buses();
  bus->set_robot_name("fumanoid-2011");
  bus->set_link("/tmp/links/ttyDXL0");
  bus->set_configured_baud_bps(1'000'000);
  recording::DeviceInfo* device = bus->add_devices();
  device->set_id(1);
  device->set_name("HEAD_PITCH");
  device->set_model("RX-28");
  device->set_protocol(1);
  add(0, "/doppel/run", "RunInfo", run);

  // The scene: carpet, further field shapes, the robot's trunk and head.
  recording::Scene scene;
  auto shape = [&](const char* type, const char* kind, uint32_t object, double x, double y, double z, double sx, double sy,
                   double sz, std::string rgb) {
    recording::Shape* s = scene.add_shapes();
    s->set_type(type);
    s->set_kind(kind);
    s->set_object_id(object);
    s->mutable_position()->set_x(x);
    s->mutable_position()->set_y(y);
    s->mutable_position()->set_z(z);
    s->mutable_orientation()->set_w(1.0);
    s->mutable_size()->set_x(sx);
    s->mutable_size()->set_y(sy);
    s->mutable_size()->set_z(sz);
    s->set_colour(rgb);
  };
  shape("box", "carpet", 0, 0, 0, -0.005, 10.4, 7.4, 0.01, std::string("\x20\x80\x20", 3));
  // Field shapes as short marks along the two side lines (y = +-3 m), out of the robot's way.
  for (int i = 0; i < f.field_shapes; ++i) {
    const double x = -4.5 + 9.0 * (i / 2) / std::max(1, f.field_shapes / 2);
    shape("box", "line", 1, x, i % 2 == 0 ? 3.0 : -3.0, 0.001, 0.1, 0.05, 0.002, "\xff\xff\xff");
  }
  shape("box", "robot", 100, 0, 0, 0.4, 0.1, 0.16, 0.2, std::string("\x30\x30\xa0", 3));
  shape("box", "robot", 100, 0, 0, 0.55, 0.06, 0.09, 0.06, std::string("\xa0\x30\x30", 3));
  add(0, "/doppel/scene", "Scene", scene);
  const int shapes = scene.shapes_size();

  // Written a second at a time (a 10-minute recording does not fit in memory as messages).
  int64_t k_world = 0, k_poses = 0, k_servos = 0, k_camera = 0, k_bus = 0;
  uint32_t sequence = 0;
  auto flush = [&] {
    std::stable_sort(messages.begin(), messages.end(), [](const Pending& a, const Pending& b) { return a.t_ns < b.t_ns; });
    for (const Pending& m : messages) {
      const auto time = static_cast<uint64_t>(kFixtureOriginNs + m.t_ns);
      writer.write(m.channel, sequence++, time, time,
                   std::span<const uint8_t>(reinterpret_cast<const uint8_t*>(m.bytes.data()), m.bytes.size()));
    }
    messages.clear();
  };
  flush();
  for (int64_t window = 1'000'000'000;; window += 1'000'000'000) {
    const int64_t until = std::min(window, end_ns + 1);
    // World state at 100 Hz from 5 ms.
    for (int64_t& k = k_world; 5'000'000 + k * 10'000'000 < until; ++k) {
      const int64_t t = 5'000'000 + k * 10'000'000;
      recording::WorldState world;
      world.set_sim_time_s(0.005 + 0.01 * static_cast<double>(k));
      world.set_missed_ticks(static_cast<uint64_t>(k / 100));
      recording::RobotState* robot = world.add_robots();
      robot->set_name("fumanoid-2011");
      robot->set_x_m(fixture_x_m(k));
      robot->set_z_m(0.0);
      robot->set_tilt_rad(fixture_tilt_rad(static_cast<double>(t) * 1e-9, f.seconds));
      robot->set_fallen(robot->tilt_rad() > 0.7853981633974483);
      for (int j = 0; j < f.joints; ++j) {
        recording::Joint* joint = robot->add_joints();
        joint->set_name("JOINT_" + std::to_string(j) + "_PITCH");
        joint->set_position_rad(0.01 * static_cast<double>(j));
      }
      recording::Imu* imu = robot->add_imus();
      imu->set_name("IMU");
      imu->set_id(100);
      imu->set_pitch_rad(robot->tilt_rad());
      for (const char* name : {"FOOT_LEFT", "FOOT_RIGHT"}) {
        recording::Foot* foot = robot->add_feet();
        foot->set_name(name);
        for (int c = 0; c < 4; ++c) foot->add_force_n(5.0);
      }
      world.mutable_ball()->set_z(0.0335);
      add(t, "/doppel/world", "WorldState", world);
    }
    // Scene poses at 30 Hz: the trunk falls forward about the feet while the robot moves along x at
    // 0.1 m/s (as the world state's x).
    for (int64_t& k = k_poses; k * 33'333'333 < until; ++k) {
      const int64_t t = k * 33'333'333;
      const double t_s = static_cast<double>(t) * 1e-9;
      const double x = 0.1 * t_s, tilt = fixture_tilt_rad(t_s, f.seconds);
      recording::ScenePoses poses;
      poses.set_sim_time_s(t_s);
      for (int i = 0; i < shapes; ++i) {
        recording::Vector3* p = poses.add_positions();
        *poses.add_orientations() = scene.shapes(i).orientation();
        *p = scene.shapes(i).position();
        if (scene.shapes(i).kind() == "robot") {
          const double height = scene.shapes(i).position().z();
          p->set_x(x + height * std::sin(tilt));
          p->set_z(height * std::cos(tilt) + 0.08 * std::sin(tilt));
          *poses.mutable_orientations(i) = about_y(tilt);
        }
      }
      add(t, "/doppel/scene_poses", "ScenePoses", poses);
    }
    // Servo tables at 10 Hz.
    for (int64_t& k = k_servos; k * 100'000'000 < until; ++k) {
      recording::ServoTables tables;
      tables.set_sim_time_s(0.1 * static_cast<double>(k));
      recording::ServoTable* table = tables.add_buses();
      table->set_robot_name("fumanoid-2011");
      table->set_link("/tmp/links/ttyDXL0");
      for (uint32_t id = 1; id <= static_cast<uint32_t>(std::max(1, f.joints)); ++id) {
        recording::ServoRow* row = table->add_servos();
        row->set_id(id);
        row->set_name("JOINT_" + std::to_string(id));
        row->set_model("RX-28");
        row->set_torque(true);
        row->set_present_position(k);
        row->set_error(-1);
      }
      add(k * 100'000'000, "/doppel/servos", "ServoTables", tables);
    }
    if (f.camera) {
      for (int64_t& k = k_camera; 250'000'000 + k * 500'000'000 < until; ++k) {
        recording::CameraImage image;
        image.set_camera("HEAD_CAMERA");
        image.set_format("png");
        image.set_data("still " + std::to_string(k));
        add(250'000'000 + k * 500'000'000, "/doppel/camera/HEAD_CAMERA", "CameraImage", image);
      }
    }
    // Bus transactions: a READ of ID 1's Present Position (P1: FF FF 01 04 02 24 02 CHK) answered
    // with position 512 (FF FF 01 04 00 00 02 CHK).
    if (f.transactions_per_s > 0) {
      const auto period = static_cast<int64_t>(1e9 / f.transactions_per_s);
      const std::string read("\xFF\xFF\x01\x04\x02\x24\x02\xD2", 8);
      const std::string status("\xFF\xFF\x01\x04\x00\x00\x02\xF8", 8);
      recording::BusTransaction transaction;
      transaction.set_protocol(1);
      transaction.set_instruction(read);
      transaction.set_checksum_ok(true);
      transaction.set_baud_bps(1'000'000);
      recording::Status* s = transaction.add_statuses();
      s->set_id(1);
      s->set_bytes(status);
      for (int64_t& k = k_bus; 1'000'000 + k * period < until; ++k) {
        const int64_t t = 1'000'000 + k * period;
        transaction.set_sequence(static_cast<uint64_t>(k));
        transaction.set_first_seen_ns(kFixtureOriginNs + t);
        transaction.set_seen_ns(kFixtureOriginNs + t + 70'000);
        transaction.set_due_ns(kFixtureOriginNs + t + 250'000);
        transaction.set_written_ns(kFixtureOriginNs + t + 260'000);
        add(t, "/doppel/bus/0/0/transactions", "BusTransaction", transaction);
      }
    }
    flush();
    if (until > end_ns) break;
  }
  writer.close();
}

}  // namespace doppel::testing
