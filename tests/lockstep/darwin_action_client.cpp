// What Linux/project/demo of the DARwIn-OP framework does to the robot, over the bus, without the
// framework's code (GPL, not vendored): written from the Protocol 1.0 e-Manual, the MX-28 and
// CM-730 control tables, and facts of the framework (darwinop-ens/darwin-op fe301d0): its start
// (Dynamixel Power on, the angle limits of Kinematics.cpp into every joint's EEPROM, every Present
// Position read, Moving Speed 0 broadcast), the goal positions and timing of Data/motion_4096.bin's
// pages 1 "init", 15 "sit down" and 9 "walkready" (each step 125 units of 7.8 ms, 32 of them
// accelerating and 32 braking; P gain 32, 8 for IDs 3 and 4 from the pages' slopes), sent every
// 8 ms as MotionManager sends them (SYNC WRITE of D, I, P, 0, Goal Position from address 26), then
// Walking (tests/physics/darwin_walking_gait.h) fed from the CM-730's gyro read over the bus.
// The page profile is a trapezoid of our own with the page's times, not Action.cpp's arithmetic.
//
//   darwin_action_client PORT WALK_SECONDS
//
// Prints per page `page=N worst_counts=C worst_id=I` (0.5 s after the page, every joint's Present
// Position against the page's goal) and `walked=S failed=F` (F: transactions not answered).
// Exit 0 when every transaction was answered, 1 otherwise, 2 on bad arguments.
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <array>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "darwin_walking_gait.h"

namespace {

namespace gait = doppel::testing::darwin_walking;

constexpr uint8_t kCm730 = 200, kBroadcast = 0xFE;
constexpr int kJoints = 20;
int port = -1;
int failed = 0;
timespec next_cycle{};

using Pose = std::array<int, kJoints + 1>;  // Goal Position by ID 1..20

// motion_4096.bin (facts): the last goal of each step of the pages played.
constexpr Pose kInit0 = {0, 1498, 2518, 1845, 2248, 2381, 1712, 2048, 2048, 2052, 2044,
                         1637, 2459, 2653, 1443, 2369, 1727, 2057, 2039, 2048, 2161};
constexpr Pose kInit1 = {0, 1480, 2610, 1747, 2343, 2147, 1944, 2047, 2047, 2047, 2047,
                         2013, 2080, 2047, 2047, 2063, 2030, 2047, 2047, 2047, 2170};
constexpr Pose kSitDown = {0, 1500, 2517, 1834, 2283, 2380, 1710, 2043, 2033, 2057, 2043,
                           1277, 2797, 3513, 571, 2843, 1240, 2077, 2037, 2050, 2173};
constexpr Pose kWalkReady = {0, 1498, 2518, 1845, 2248, 2381, 1712, 2048, 2048, 2052, 2044,
                             1637, 2459, 2653, 1443, 2389, 1707, 2057, 2039, 2048, 2161};

// Kinematics.cpp's angle limits (deg) of IDs 3..20, CW then CCW (IDs 1 and 2 have none).
constexpr double kLimits[kJoints + 1][2] = {
    {0, 0},     {0, 0},     {0, 0},     {-75, 135}, {-135, 75}, {-95, 70},  {-70, 95},
    {-123, 53}, {-53, 123}, {-45, 59},  {-59, 45},  {-100, 29}, {-29, 100}, {-6, 130},
    {-130, 6},  {-72, 80},  {-80, 72},  {-44, 63},  {-63, 44},  {-90, 90},  {-25, 55}};

void send_packet(uint8_t id, uint8_t instruction, const uint8_t* params, int n) {
  std::vector<uint8_t> packet = {0xFF, 0xFF, id, static_cast<uint8_t>(n + 2), instruction};
  packet.insert(packet.end(), params, params + n);
  uint8_t sum = 0;
  for (size_t i = 2; i < packet.size(); ++i) sum = static_cast<uint8_t>(sum + packet[i]);
  packet.push_back(static_cast<uint8_t>(~sum));
  if (write(port, packet.data(), packet.size()) != static_cast<ssize_t>(packet.size())) {
    std::perror("write");
    std::exit(1);
  }
}

// A status of `params` parameter bytes from `id`, waited for with poll() (simulation time under
// lockstep); false when it does not come within 20 ms or is not that servo's.
bool receive(uint8_t id, uint8_t* out, int params) {
  const int expected = params + 6;
  uint8_t buffer[64];
  int got = 0;
  while (got < expected) {
    pollfd p{port, POLLIN, 0};
    if (poll(&p, 1, 20) <= 0) break;
    const ssize_t n = read(port, buffer + got, static_cast<size_t>(expected - got));
    if (n > 0) got += static_cast<int>(n);
  }
  if (got != expected || buffer[0] != 0xFF || buffer[1] != 0xFF || buffer[2] != id) {
    ++failed;
    return false;
  }
  if (out != nullptr) std::memcpy(out, buffer + 5, static_cast<size_t>(params));
  return true;
}

void write_word(uint8_t id, uint8_t address, int value) {
  const uint8_t params[3] = {address, static_cast<uint8_t>(value & 0xFF), static_cast<uint8_t>(value >> 8)};
  send_packet(id, 0x03, params, 3);
  if (id != kBroadcast) receive(id, nullptr, 0);
}

int read_word(uint8_t id, uint8_t address) {
  const uint8_t params[2] = {address, 2};
  send_packet(id, 0x02, params, 2);
  uint8_t value[2] = {0, 0};
  return receive(id, value, 2) ? value[0] | value[1] << 8 : -1;
}

void wait_cycle() {
  next_cycle.tv_nsec += 8'000'000;
  if (next_cycle.tv_nsec >= 1'000'000'000) {
    next_cycle.tv_nsec -= 1'000'000'000;
    ++next_cycle.tv_sec;
  }
  clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next_cycle, nullptr);
}

// One 8 ms cycle of MotionManager: SYNC WRITE of D, I, P, 0, Goal Position (address 26) to 1..20.
void send_pose(const Pose& goal, const std::array<int, kJoints + 1>& p_gain) {
  uint8_t params[2 + kJoints * 7];
  params[0] = 26;
  params[1] = 6;
  for (int id = 1; id <= kJoints; ++id) {
    uint8_t* q = params + 2 + (id - 1) * 7;
    q[0] = static_cast<uint8_t>(id);
    q[1] = 0;
    q[2] = 0;
    q[3] = static_cast<uint8_t>(p_gain[id]);
    q[4] = 0;
    q[5] = static_cast<uint8_t>(goal[id] & 0xFF);
    q[6] = static_cast<uint8_t>(goal[id] >> 8);
  }
  send_packet(kBroadcast, 0x83, params, sizeof params);
}

std::array<int, kJoints + 1> page_gains() {
  std::array<int, kJoints + 1> g{};
  g.fill(32);
  g[3] = g[4] = 8;
  return g;
}

// From `from` to `to` in 125 cycles: 32 accelerating, 32 braking, constant speed between.
void play_step(Pose& current, const Pose& to) {
  constexpr double kTotal = 125, kRamp = 32, kPeak = 1.0 / (kTotal - kRamp);
  const Pose from = current;
  for (int k = 1; k <= kTotal; ++k) {
    double s = 0;
    if (k < kRamp) {
      s = 0.5 * kPeak * k * k / kRamp;
    } else if (k <= kTotal - kRamp) {
      s = 0.5 * kPeak * kRamp + kPeak * (k - kRamp);
    } else {
      s = 1.0 - 0.5 * kPeak * (kTotal - k) * (kTotal - k) / kRamp;
    }
    for (int id = 1; id <= kJoints; ++id) current[id] = from[id] + static_cast<int>(std::lround(s * (to[id] - from[id])));
    send_pose(current, page_gains());
    wait_cycle();
  }
}

// Holds the page's goal 0.5 s, then reads every joint and prints how far the worst one is.
void finish_page(int page, const Pose& goal) {
  for (int i = 0; i < 62; ++i) {
    send_pose(goal, page_gains());
    wait_cycle();
  }
  int worst = -1, worst_id = 0;
  for (int id = 1; id <= kJoints; ++id) {
    const int present = read_word(static_cast<uint8_t>(id), 36);
    const int off = present < 0 ? 4096 : std::abs(present - goal[id]);
    if (off > worst) worst = off, worst_id = id;
  }
  std::printf("page=%d worst_counts=%d worst_id=%d\n", page, worst, worst_id);
  clock_gettime(CLOCK_MONOTONIC, &next_cycle);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3 || std::atof(argv[2]) <= 0) {
    std::fprintf(stderr, "usage: %s PORT WALK_SECONDS\n", argv[0]);
    return 2;
  }
  port = open(argv[1], O_RDWR | O_NOCTTY | O_NONBLOCK);
  if (port < 0) {
    std::perror(argv[1]);
    return 1;
  }
  termios tio{};
  tio.c_cflag = CS8 | CLOCAL | CREAD;
  cfsetispeed(&tio, B1000000);
  cfsetospeed(&tio, B1000000);
  tcsetattr(port, TCSANOW, &tio);
  tcflush(port, TCIFLUSH);

  const uint8_t power[2] = {24, 1};  // CM-730 Dynamixel Power on
  send_packet(kCm730, 0x03, power, 2);
  receive(kCm730, nullptr, 0);
  usleep(300'000);
  for (int id = 3; id <= kJoints; ++id) {
    write_word(static_cast<uint8_t>(id), 6, gait::angle_to_value(kLimits[id][0]));
    write_word(static_cast<uint8_t>(id), 8, gait::angle_to_value(kLimits[id][1]));
  }
  Pose current{};
  for (int id = 1; id <= kJoints; ++id) current[id] = read_word(static_cast<uint8_t>(id), 36);
  write_word(kBroadcast, 32, 0);  // Moving Speed 0: the servos' own top speed

  clock_gettime(CLOCK_MONOTONIC, &next_cycle);
  play_step(current, kInit0);
  play_step(current, kInit1);
  finish_page(1, kInit1);
  play_step(current, kSitDown);
  finish_page(15, kSitDown);
  play_step(current, kWalkReady);
  finish_page(9, kWalkReady);

  // Walking takes IDs 1..18 (legs P 32, arms 8), the head keeps the page's pose; the gyro's
  // centre is the mean of 100 cycles standing, as MotionManager calibrates it.
  gait::Walking walking;
  std::array<int, kJoints + 1> gains{};
  gains.fill(32);
  for (int id = 1; id <= 6; ++id) gains[id] = 8;
  int fb = 0, rl = 0;
  double fb_centre = 512, rl_centre = 512;
  std::array<double, 2> sums{};
  auto cycle = [&](bool calibrating) {
    const gait::Goals& goals = walking.process(fb, rl);
    for (int id = 1; id <= 18; ++id) current[id] = goals[id];
    send_pose(current, gains);
    const int gyro_y = read_word(kCm730, 40), gyro_x = read_word(kCm730, 42);
    if (calibrating) {
      sums[0] += gyro_y;
      sums[1] += gyro_x;
    } else {
      fb = gyro_y - static_cast<int>(fb_centre);
      rl = gyro_x - static_cast<int>(rl_centre);
    }
    wait_cycle();
  };
  for (int i = 0; i < 100; ++i) cycle(true);
  fb_centre = sums[0] / 100;
  rl_centre = sums[1] / 100;
  walking.x_amplitude = 15;
  walking.start();
  const int cycles = static_cast<int>(std::atof(argv[2]) * 1000 / gait::kTimeUnitMs);
  for (int i = 0; i < cycles; ++i) cycle(false);
  walking.stop();
  for (int i = 0; i < 125; ++i) cycle(false);
  std::printf("walked=%s failed=%d\n", argv[2], failed);
  return failed == 0 ? 0 : 1;
}
