// Plays the DARwIn-OP framework's Action pages from Data/motion_4096.bin and then walks, as its
// Linux/project/demo does (Action, Head and Walking modules; page 15 "sit down" at start, page 9
// "walkready" before Walking takes the body without the head, gyro recalibrated). Uses only the
// framework's API (darwinop-ens/darwin-op, unmodified, built by scripts/check-darwin-framework).
//
// action PORT INI MOTION_FILE X_MM SECONDS
// Plays pages 1 "init", 15 "sit down", 9 "walkready", then walks SECONDS at X_MM. Prints each
// page's end and the fall flag; exit 3 when the start did not come up (gyro not calibrated within
// 5 s), 4 when a page does not play, 0 otherwise.
#include <cstdio>
#include <cstdlib>
#include <unistd.h>

#include "LinuxDARwIn.h"

using namespace Robot;

static bool calibrated() {
  for (int i = 0; i < 625 && MotionManager::GetInstance()->GetCalibrationStatus() != 1; ++i) usleep(8000);
  return MotionManager::GetInstance()->GetCalibrationStatus() == 1;
}

static bool play(int page) {
  if (!Action::GetInstance()->Start(page)) {
    std::printf("page %d: Action::Start refused it\n", page);
    return false;
  }
  int cycles = 0;
  while (Action::GetInstance()->IsRunning() && cycles < 2500) {
    usleep(8000);
    ++cycles;
  }
  std::printf("page %d played, fallen %d\n", page, (int)MotionStatus::FALLEN);
  std::fflush(stdout);
  return !Action::GetInstance()->IsRunning();
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
  if (!play(1) || !play(15) || !play(9)) {
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
