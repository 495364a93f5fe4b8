// Plays the DARwIn-OP framework's Action pages from Data/motion_4096.bin and then walks, as its
// Linux/project/demo does (Action, Head and Walking modules; page 15 "sit down" at start, page 9
// "walkready" before Walking takes the body without the head, gyro recalibrated). Uses only the
// framework's API (darwinop-ens/darwin-op, unmodified, built by scripts/check-darwin-framework).
//
// action PORT INI MOTION_FILE X_MM SECONDS
// Plays pages 1 "init", 15 "sit down", 9 "walkready", then walks SECONDS at X_MM. After each page
// it holds 0.5 s and reads every joint's Present Position with the framework's CM730::ReadWord
// (as the demo reads the firmware version, from the main thread while the timer runs), and prints
// how far each is from the page's last goal (`page N NAME: ... worst C counts at ID ..., mean M`)
// and the fall flag; `walk: start at CLOCK_MONOTONIC T s` before Walking::Start (under
// doppel-run --lockstep that clock is 1000 s + simulation time). Exit 3 when the start did not
// come up (gyro not calibrated within 5 s), 4 when a page does not play, 0 otherwise.
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <unistd.h>

#include "LinuxDARwIn.h"

using namespace Robot;

static bool calibrated() {
  for (int i = 0; i < 625 && MotionManager::GetInstance()->GetCalibrationStatus() != 1; ++i) usleep(8000);
  return MotionManager::GetInstance()->GetCalibrationStatus() == 1;
}

// Present Position of every joint against the page's last step (plus MotionManager's offsets),
// read 0.5 s after the page ended.
static void report_pose(CM730* cm730, int page) {
  Action::PAGE p;
  if (!Action::GetInstance()->LoadPage(page, &p) || p.header.stepnum == 0) return;
  const Action::STEP& last = p.step[p.header.stepnum - 1];
  int worst = -1, worst_id = 0, sum = 0, joints = 0, unread = 0;
  for (int id = JointData::ID_R_SHOULDER_PITCH; id < JointData::NUMBER_OF_JOINTS; ++id) {
    if (last.position[id] & Action::INVALID_BIT_MASK) continue;
    int value = 0;
    if (cm730->ReadWord(id, MX28::P_PRESENT_POSITION_L, &value, 0) != CM730::SUCCESS) {
      ++unread;
      continue;
    }
    const int goal = last.position[id] + MotionManager::GetInstance()->m_Offset[id];
    const int off = value > goal ? value - goal : goal - value;
    sum += off;
    ++joints;
    if (off > worst) {
      worst = off;
      worst_id = id;
    }
  }
  std::printf("page %d %s: %d joints read (%d not), worst %d counts (%.1f deg) at ID %d, mean %.1f counts (%.1f deg); fallen %d\n",
              page, (const char*)p.header.name, joints, unread, worst, worst * 360.0 / 4096, worst_id,
              joints ? (double)sum / joints : 0.0, joints ? sum * 360.0 / 4096 / joints : 0.0, (int)MotionStatus::FALLEN);
  std::fflush(stdout);
}

static bool play(CM730* cm730, int page) {
  if (!Action::GetInstance()->Start(page)) {
    std::printf("page %d: Action::Start refused it\n", page);
    return false;
  }
  int cycles = 0;
  while (Action::GetInstance()->IsRunning() && cycles < 2500) {
    usleep(8000);
    ++cycles;
  }
  if (Action::GetInstance()->IsRunning()) {
    std::printf("page %d still playing after 20 s\n", page);
    return false;
  }
  usleep(500000);
  report_pose(cm730, page);
  return true;
}

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: %s PORT INI MOTION_FILE X_MM SECONDS\n", argv[0]);
    return 2;
  }
  const double x_mm = std::atof(argv[4]);
  const int seconds = std::atoi(argv[5]);

  minIni* ini = new minIni(argv[2]);
  LinuxCM730* linux_cm730 = new LinuxCM730(argv[1]);
  CM730* cm730 = new CM730(linux_cm730);
  if (!MotionManager::GetInstance()->Initialize(cm730)) {
    std::printf("start: Fail to initialize Motion Manager!\n");
    return 3;
  }
  Walking::GetInstance()->LoadINISettings(ini);
  MotionManager::GetInstance()->AddModule((MotionModule*)Action::GetInstance());
  MotionManager::GetInstance()->AddModule((MotionModule*)Head::GetInstance());
  MotionManager::GetInstance()->AddModule((MotionModule*)Walking::GetInstance());
  LinuxMotionTimer* motion_timer = new LinuxMotionTimer(MotionManager::GetInstance());
  motion_timer->Start();
  MotionManager::GetInstance()->LoadINISettings(ini);

  if (!Action::GetInstance()->LoadFile(argv[3])) {
    std::printf("start: cannot load %s\n", argv[3]);
    motion_timer->Stop();
    return 2;
  }
  Action::GetInstance()->m_Joint.SetEnableBody(true, true);
  MotionManager::GetInstance()->SetEnable(true);
  if (!calibrated()) {
    std::printf("start: gyro not calibrated: the CM-730 is not in the BULK READ\n");
    motion_timer->Stop();
    return 3;
  }
  std::printf("start: calibrated\n");
  if (!play(cm730, 1) || !play(cm730, 15) || !play(cm730, 9)) {
    motion_timer->Stop();
    return 4;
  }

  Head::GetInstance()->m_Joint.SetEnableHeadOnly(true, true);
  Walking::GetInstance()->m_Joint.SetEnableBodyWithoutHead(true, true);
  MotionManager::GetInstance()->ResetGyroCalibration();
  if (!calibrated()) {
    std::printf("walk: gyro recalibration failed\n");
    motion_timer->Stop();
    return 3;
  }
  Walking::GetInstance()->X_MOVE_AMPLITUDE = x_mm;
  Walking::GetInstance()->A_MOVE_AMPLITUDE = 0;
  timespec now;
  clock_gettime(CLOCK_MONOTONIC, &now);
  std::printf("walk: start at CLOCK_MONOTONIC %.3f s\n", now.tv_sec + now.tv_nsec * 1e-9);
  std::fflush(stdout);
  Walking::GetInstance()->Start();
  int fallen_at = -1;
  for (int s = 1; s <= seconds; ++s) {
    sleep(1);
    if (fallen_at < 0 && MotionStatus::FALLEN != STANDUP) fallen_at = s;
  }
  Walking::GetInstance()->Stop();
  for (int i = 0; i < 250 && Walking::GetInstance()->IsRunning(); ++i) usleep(8000);
  std::printf("done: walked %d s, framework's fall flag first at %d s (-1 never)\n", seconds, fallen_at);
  motion_timer->Stop();
  return 0;
}
