#include "record/recorder.h"

#include <cstdio>
#include <iomanip>
#include <map>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "base/monotonic_clock.h"
#include "record/bus_transcriber.h"
#include "recording/topics.h"

namespace doppel::record {

namespace {

using Clock = std::chrono::steady_clock;

recording::Vector3 vector3(double x, double y, double z) {
  recording::Vector3 v;
  v.set_x(x);
  v.set_y(y);
  v.set_z(z);
  return v;
}

recording::WorldState world_state(const contract::SimState& state) {
  recording::WorldState out;
  out.set_sim_time_s(state.sim_time_s);
  out.set_paused(state.paused);
  out.set_missed_ticks(state.missed_ticks);
  if (state.ball_m && state.ball_m->size() == 3) {
    *out.mutable_ball() = vector3((*state.ball_m)[0], (*state.ball_m)[1], (*state.ball_m)[2]);
  }
  for (const contract::RobotState& robot : state.robots) {
    recording::RobotState* r = out.add_robots();
    r->set_name(robot.name);
    r->set_x_m(robot.x_m);
    r->set_y_m(robot.y_m);
    r->set_z_m(robot.z_m);
    r->set_yaw_rad(robot.yaw_rad);
    r->set_tilt_rad(robot.tilt_rad);
    r->set_fallen(robot.fallen);
    r->set_held(robot.held);
    for (const contract::JointState& joint : robot.joints) {
      recording::Joint* j = r->add_joints();
      j->set_name(joint.name);
      j->set_position_rad(joint.position_rad);
    }
    for (const contract::ImuReading& imu : robot.imus) {
      recording::Imu* i = r->add_imus();
      i->set_name(imu.name);
      i->set_bus(imu.bus);
      i->set_id(imu.id);
      i->set_roll_rad(imu.roll_rad);
      i->set_pitch_rad(imu.pitch_rad);
      *i->mutable_gyro_rad_s() = vector3(imu.gyro_rad_s[0], imu.gyro_rad_s[1], imu.gyro_rad_s[2]);
    }
    for (const contract::FootReading& foot : robot.feet) {
      recording::Foot* f = r->add_feet();
      f->set_name(foot.name);
      f->set_bus(foot.bus);
      f->set_id(foot.id);
      for (double force : foot.force_n) f->add_force_n(force);
    }
  }
  return out;
}

recording::ServoTables servo_tables(double sim_time_s, const std::vector<contract::BusTable>& tables) {
  recording::ServoTables out;
  out.set_sim_time_s(sim_time_s);
  for (const contract::BusTable& table : tables) {
    recording::ServoTable* t = out.add_buses();
    t->set_robot(static_cast<uint32_t>(table.robot));
    t->set_robot_name(table.robot_name);
    t->set_bus(static_cast<uint32_t>(table.bus));
    t->set_link(table.link);
    for (const contract::ServoRow& row : table.servos) {
      recording::ServoRow* s = t->add_servos();
      s->set_id(row.id);
      s->set_name(row.name);
      s->set_model(row.model);
      s->set_torque(row.torque);
      s->set_goal_position(row.goal_position);
      s->set_present_position(row.present_position);
      s->set_present_speed(row.present_speed);
      s->set_present_load(row.present_load);
      s->set_temperature(row.temperature);
      s->set_voltage(row.voltage);
      s->set_error(row.error);
    }
  }
  return out;
}

recording::Scene scene_shapes(const contract::Scene& scene) {
  recording::Scene out;
  out.set_sim_time_s(scene.sim_time_s);
  for (const contract::SceneShape& shape : scene.shapes) {
    recording::Shape* s = out.add_shapes();
    s->set_type(shape.type);
    s->set_kind(shape.kind);
    s->set_object_id(shape.object_id);
    *s->mutable_position() = vector3(shape.position[0], shape.position[1], shape.position[2]);
    recording::Quaternion* q = s->mutable_orientation();
    q->set_x(shape.quaternion[0]);
    q->set_y(shape.quaternion[1]);
    q->set_z(shape.quaternion[2]);
    q->set_w(shape.quaternion[3]);
    *s->mutable_size() = vector3(shape.size[0], shape.size[1], shape.size[2]);
    s->set_colour(std::string(shape.colour.begin(), shape.colour.end()));
    for (double v : shape.vertices) s->add_vertices(v);
    for (unsigned t : shape.triangles) s->add_triangles(t);
  }
  return out;
}

recording::ScenePoses scene_poses(const contract::Scene& scene) {
  recording::ScenePoses out;
  out.set_sim_time_s(scene.sim_time_s);
  for (const contract::SceneShape& shape : scene.shapes) {
    *out.add_positions() = vector3(shape.position[0], shape.position[1], shape.position[2]);
    recording::Quaternion* q = out.add_orientations();
    q->set_x(shape.quaternion[0]);
    q->set_y(shape.quaternion[1]);
    q->set_z(shape.quaternion[2]);
    q->set_w(shape.quaternion[3]);
  }
  return out;
}

// What identifies a scene's set of shapes: when it changes, the whole geometry is written again.
std::string scene_signature(const contract::Scene& scene) {
  std::string out;
  for (const contract::SceneShape& shape : scene.shapes) {
    out += shape.type;
    out += shape.kind;
    out += std::to_string(shape.object_id) + ":" + std::to_string(shape.vertices.size()) + ";";
  }
  return out;
}

}  // namespace

struct Recorder::Impl {
  RecorderOptions options;
  recording::RunInfo run;
  std::vector<RecordedBus> buses;
  contract::Facets control;  // simulation null: no servo tables, scene or stills
  contract::StateQueue* world_states = nullptr;  // null: no world state
  std::ostream* progress_out = nullptr;
  std::unique_ptr<mcap::Writer> writer;
  std::vector<BusTranscriber> transcribers;
  std::map<std::string, uint16_t> schemas;   // message full name -> schema id
  std::map<std::string, uint16_t> channels;  // topic -> channel id
  std::map<uint16_t, uint32_t> sequences;    // channel -> next sequence
  std::string buffer;
  std::atomic<bool> stop{false};
  std::thread thread;
  bool started = false;
  bool stopped = false;
  std::string error;        // the first write error; nothing is written after it
  std::string scene_signature;
  std::string fault_signature;  // the fault list last written (numbers, ends, active flags)
  double last_world_time_s = -1.0;
  contract::SimState world;  // the recorder thread's copy of the state being written
  std::atomic<uint64_t> messages{0}, transactions{0}, bytes{0};
  bus::TapEvent event;
  std::vector<uint8_t> payload;

  uint16_t channel(const std::string& topic, const google::protobuf::Descriptor& descriptor) {
    if (auto it = channels.find(topic); it != channels.end()) return it->second;
    uint16_t schema = 0;
    if (auto it = schemas.find(descriptor.full_name()); it != schemas.end()) {
      schema = it->second;
    } else {
      schema = writer->add_schema(descriptor.full_name(), std::string(recording::kEncoding),
                                  recording::protobuf_schema(descriptor));
      schemas[descriptor.full_name()] = schema;
    }
    const uint16_t id = writer->add_channel(schema, topic, std::string(recording::kEncoding));
    channels[topic] = id;
    return id;
  }

  void write(const std::string& topic, const google::protobuf::Message& message, int64_t log_time_ns) {
    if (!error.empty()) return;
    try {
      const uint16_t id = channel(topic, *message.GetDescriptor());
      message.SerializeToString(&buffer);
      const auto time = static_cast<uint64_t>(std::max<int64_t>(log_time_ns, 0));
      writer->write(id, sequences[id]++, time, time,
                    {reinterpret_cast<const uint8_t*>(buffer.data()), buffer.size()});
      messages.fetch_add(1, std::memory_order_relaxed);
      bytes.store(writer->counters().bytes, std::memory_order_relaxed);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }

  void drain_taps() {
    for (std::size_t i = 0; i < buses.size(); ++i) {
      while (buses[i].tap->pop(event, payload)) transcribers[i].feed(event, payload);
    }
  }

  uint64_t dropped_world_states() const { return world_states != nullptr ? world_states->lost() : 0; }

  uint64_t dropped_bus_events() const {
    uint64_t n = 0;
    for (const RecordedBus& bus : buses) n += bus.tap->dropped();
    return n;
  }

  // Every state the simulation published since the last call (100 Hz of simulation time); a
  // paused simulation publishes the same moment again, written once.
  void drain_world(int64_t now_ns) {
    if (world_states == nullptr) return;
    while (world_states->pop(world)) {
      if (world.sim_time_s == last_world_time_s) continue;
      last_world_time_s = world.sim_time_s;
      write(std::string(recording::kWorldTopic), world_state(world), now_ns);
    }
  }

  // The faults topic: the whole list whenever a fault was added or cleared, or started or ended.
  void sample_faults(int64_t now_ns, bool force = false) {
    if (control.faults == nullptr) return;
    const contract::FaultList list = control.faults->faults();
    std::string signature;
    recording::FaultList message;
    message.set_sim_time_s(list.sim_time_s);
    for (const contract::FaultEntry& entry : list.faults) {
      const faults::Fault& f = entry.fault;
      const faults::FaultKindInfo& info = faults::info(f.spec.kind);
      signature += std::to_string(f.number) + ":" + std::to_string(f.end_ns) + (entry.active ? "+" : "-") + ",";
      recording::Fault* out = message.add_faults();
      out->set_number(f.number);
      out->set_kind(std::string(info.name));
      out->set_robot(f.spec.robot);
      out->set_bus(f.spec.bus);
      out->set_id(f.spec.id);
      out->set_start_s(static_cast<double>(f.start_ns) * 1e-9);
      out->set_until_cleared(f.end_ns == INT64_MAX);
      if (f.end_ns != INT64_MAX) out->set_end_s(static_cast<double>(f.end_ns) * 1e-9);
      out->set_value_field(std::string(info.value_field));
      out->set_value(f.spec.value);
      out->set_rate(f.spec.rate);
      out->set_seed(f.spec.seed);
      out->set_active(entry.active);
    }
    if (list.faults.empty() || (!force && signature == fault_signature)) return;
    fault_signature = signature;
    write(std::string(recording::kFaultsTopic), message, now_ns);
  }

  void sample_scene(int64_t now_ns) {
    const contract::Scene scene = control.simulation->scene();
    if (scene.shapes.empty()) return;
    const std::string signature = record::scene_signature(scene);
    if (signature != scene_signature) {
      scene_signature = signature;
      write(std::string(recording::kSceneTopic), scene_shapes(scene), now_ns);
    }
    write(std::string(recording::kScenePosesTopic), scene_poses(scene), now_ns);
  }

  void sample_cameras(int64_t now_ns) {
    const contract::SimState state = control.simulation->state();
    for (const contract::RobotState& robot : state.robots) {
      for (const contract::CameraView& camera : robot.cameras) {
        const contract::Result<contract::CameraStill> answer = control.simulation->camera_still(camera.name);
        if (!answer.ok()) continue;
        const contract::CameraStill& still = answer.value();
        recording::CameraImage image;
        image.set_sim_time_s(still.sim_time_s);
        image.set_camera(camera.name);
        image.set_format("png");
        image.set_data(still.png);
        write(recording::camera_topic(camera.name), image, now_ns);
      }
    }
  }

  void print_progress() {
    if (!options.progress || progress_out == nullptr) return;
    char line[200];
    std::snprintf(line, sizeof(line), "\rdoppel: recording %s: %.1f MB, %llu messages, %llu bus events dropped   ",
                  options.path.c_str(), static_cast<double>(bytes.load()) / 1e6,
                  static_cast<unsigned long long>(messages.load()), static_cast<unsigned long long>(dropped_bus_events()));
    *progress_out << line << std::flush;
  }

  void loop() {
    using std::chrono::duration;
    auto period = [](double hz) { return std::chrono::duration_cast<Clock::duration>(duration<double>(1.0 / hz)); };
    const Clock::time_point begin = Clock::now();
    Clock::time_point next_servo = begin, next_scene = begin, next_camera = begin;
    Clock::time_point next_flush = begin + options.flush_every, next_progress = begin + std::chrono::seconds(1);
    while (!stop.load(std::memory_order_acquire)) {
      drain_taps();
      const Clock::time_point now = Clock::now();
      const int64_t now_ns = monotonic_now_ns();
      drain_world(now_ns);
      if (control.simulation != nullptr) {
        sample_faults(now_ns);
        if (options.servo_hz > 0 && now >= next_servo) {
          write(std::string(recording::kServosTopic), servo_tables(last_world_time_s, control.simulation->buses()), now_ns);
          next_servo = std::max(next_servo + period(options.servo_hz), now);
        }
        if (options.scene_hz > 0 && now >= next_scene) {
          sample_scene(now_ns);
          next_scene = std::max(next_scene + period(options.scene_hz), now);
        }
        if (options.camera_hz > 0 && now >= next_camera) {
          sample_cameras(now_ns);
          next_camera = std::max(next_camera + period(options.camera_hz), now);
        }
      }
      if (now >= next_flush) {
        if (error.empty()) {
          try {
            writer->flush();
          } catch (const std::exception& e) {
            error = e.what();
          }
        }
        next_flush = now + options.flush_every;
      }
      if (now >= next_progress) {
        print_progress();
        next_progress = now + std::chrono::seconds(1);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  }
};

Recorder::Recorder(const RecorderOptions& options, recording::RunInfo run, std::vector<RecordedBus> buses,
                   contract::Facets control, contract::StateQueue* world_states, std::ostream* progress_out)
    : impl_(std::make_unique<Impl>()) {
  Impl& d = *impl_;
  d.options = options;
  d.run = std::move(run);
  d.buses = std::move(buses);
  d.control = control;
  d.world_states = world_states;
  d.progress_out = progress_out;
  mcap::WriterOptions writer_options;
  writer_options.profile = "doppel";
  writer_options.compression = options.compression;
  d.writer = std::make_unique<mcap::Writer>(options.path, writer_options);  // throws naming the file
  for (const RecordedBus& bus : d.buses) {
    if (bus.tap == nullptr) throw std::invalid_argument("Recorder: a bus without a tap");
    *d.run.add_buses() = bus.info;
  }
  for (const RecordedBus& bus : d.buses) {
    const recording::BusInfo& info = bus.info;
    Impl* impl = &d;
    TranscriptSink sink;
    const std::string transactions = recording::bus_topic(info.robot(), info.bus(), recording::BusStream::kTransactions);
    const std::string input = recording::bus_topic(info.robot(), info.bus(), recording::BusStream::kInput);
    const std::string events = recording::bus_topic(info.robot(), info.bus(), recording::BusStream::kEvents);
    sink.transaction = [impl, transactions](const recording::BusTransaction& t) {
      impl->write(transactions, t, t.first_seen_ns() != 0 ? t.first_seen_ns() : t.seen_ns());
      impl->transactions.fetch_add(1, std::memory_order_relaxed);
    };
    sink.noise = [impl, input](const recording::BusNoise& n) { impl->write(input, n, n.seen_ns()); };
    sink.event = [impl, events](const recording::BusEvent& e) { impl->write(events, e, e.time_ns()); };
    d.transcribers.emplace_back(info.robot(), info.bus(), info.adapter(), std::move(sink));
  }
  d.write(std::string(recording::kRunTopic), d.run, d.run.start_monotonic_ns());
  if (!d.error.empty()) throw std::runtime_error(d.error);
}

Recorder::~Recorder() { stop(); }

void Recorder::start() {
  if (impl_->started) return;
  impl_->started = true;
  impl_->thread = std::thread([this] {
    pthread_setname_np(pthread_self(), "doppel-record");
    impl_->loop();
  });
}

void Recorder::stop() {
  Impl& d = *impl_;
  if (d.stopped) return;
  d.stopped = true;
  d.stop.store(true, std::memory_order_release);
  if (d.thread.joinable()) d.thread.join();
  d.drain_taps();
  d.drain_world(monotonic_now_ns());
  for (BusTranscriber& transcriber : d.transcribers) transcriber.finish();
  if (d.control.simulation != nullptr) d.sample_faults(monotonic_now_ns(), true);  // every fault's end as it stands
  recording::RecordingSummary summary;
  summary.set_messages(d.messages.load() + 1);
  summary.set_dropped_bus_events(d.dropped_bus_events());
  summary.set_dropped_world_states(d.dropped_world_states());
  summary.set_bytes_written(d.bytes.load());
  d.write(std::string(recording::kSummaryTopic), summary, monotonic_now_ns());
  if (d.error.empty()) {
    try {
      d.writer->close();
      d.bytes.store(d.writer->counters().bytes);
    } catch (const std::exception& e) {
      d.error = e.what();
    }
  }
  if (d.options.progress && d.progress_out != nullptr && d.started) *d.progress_out << "\n";
}

RecorderTotals Recorder::totals() const {
  RecorderTotals totals;
  totals.messages = impl_->messages.load();
  totals.transactions = impl_->transactions.load();
  totals.bytes = impl_->bytes.load();
  totals.dropped_bus_events = impl_->dropped_bus_events();
  totals.dropped_world_states = impl_->dropped_world_states();
  return totals;
}

std::string Recorder::summary() const {
  const RecorderTotals t = totals();
  std::ostringstream out;
  out << "  recording " << impl_->options.path << ": " << t.messages << " messages (" << t.transactions
      << " bus transactions), " << std::fixed << std::setprecision(1) << static_cast<double>(t.bytes) / 1e6 << " MB, " << t.dropped_bus_events
      << " bus events dropped, " << t.dropped_world_states << " world states dropped\n";
  if (!impl_->error.empty()) out << "  recording FAILED: " << impl_->error << " (the file ends there)\n";
  return out.str();
}

}  // namespace doppel::record
