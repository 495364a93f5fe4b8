// Runs the DARwIn-OP framework's own Walking module (darwinop-ens/darwin-op, unmodified, built by
// scripts/check-darwin-framework) on a port: started as Linux/project/tutorial/ball_following
// starts it, then Walking with its constructor's parameters (no [Walking Config] in config.ini)
// at the commanded X and A amplitudes. Written against the framework's API only; it is not part
// of the framework and the framework is not part of Doppel.
//
// walk PORT INI X_MM A_DEG SECONDS
// Prints one line per second (time, FALLEN, FB/RL gyro, calibration) and a summary; exit 3 when
// the start did not come up (gyro not calibrated within 5 s: the CM-730 missing from the BULK
// READ), 0 otherwise. The distance is measured on Doppel's side (doppel-ctl state).
#include <cstdio>
#include <cstdlib>
#include <unistd.h>

#include "LinuxDARwIn.h"
#include "walking_pose.h"

using namespace Robot;

int main(int argc, char** argv) {
  if (argc != 6) {
    std::fprintf(stderr, "usage: %s PORT INI X_MM A_DEG SECONDS\n", argv[0]);
    return 2;
  }
  const double x_mm = std::atof(argv[3]);
  const double a_deg = std::atof(argv[4]);
  const int seconds = std::atoi(argv[5]);

  minIni* ini = new minIni(argv[2]);
  LinuxCM730* linux_cm730 = new LinuxCM730(argv[1]);
  CM730* cm730 = new CM730(linux_cm730);
  if (!MotionManager::GetInstance()->Initialize(cm730)) {
    std::printf("start: Fail to initialize Motion Manager!\n");
    return 3;
  }
  MotionManager::GetInstance()->LoadINISettings(ini);
  Walking::GetInstance()->LoadINISettings(ini);
  MotionManager::GetInstance()->AddModule((MotionModule*)Head::GetInstance());
  MotionManager::GetInstance()->AddModule((MotionModule*)Walking::GetInstance());
  LinuxMotionTimer* motion_timer = new LinuxMotionTimer(MotionManager::GetInstance());
  motion_timer->Start();

  sync_write_walking_pose(*cm730);

  Head::GetInstance()->m_Joint.SetEnableHeadOnly(true, true);
  Walking::GetInstance()->m_Joint.SetEnableBodyWithoutHead(true, true);
  MotionManager::GetInstance()->SetEnable(true);

  for (int i = 0; i < 625 && MotionManager::GetInstance()->GetCalibrationStatus() != 1; ++i) usleep(8000);
  if (MotionManager::GetInstance()->GetCalibrationStatus() != 1) {
    std::printf("start: gyro not calibrated (status %d): the CM-730 is not in the BULK READ\n",
                MotionManager::GetInstance()->GetCalibrationStatus());
    motion_timer->Stop();
    return 3;
  }
  // A joint Initialize could not read is never commanded (MotionManager::Process skips it): on a
  // loaded machine its main thread can be preempted past the read's own 5 ms window.
  int joints = 0;
  for (int id = JointData::ID_R_SHOULDER_PITCH; id < JointData::NUMBER_OF_JOINTS; id++) {
    if (MotionStatus::m_CurrentJoints.GetEnable(id)) joints++;
  }
  if (joints < JointData::NUMBER_OF_JOINTS - 1) {
    std::printf("start: Initialize read %d of %d joints; the others would stay uncommanded\n", joints,
                JointData::NUMBER_OF_JOINTS - 1);
    motion_timer->Stop();
    return 3;
  }
  std::printf("start: calibrated\n");
  sleep(1);  // Walking's standing pose at P 32 settles

  Walking::GetInstance()->X_MOVE_AMPLITUDE = x_mm;
  Walking::GetInstance()->A_MOVE_AMPLITUDE = a_deg;
  Walking::GetInstance()->Start();
  int fallen_at = -1;
  for (int s = 1; s <= seconds; ++s) {
    sleep(1);
    if (fallen_at < 0 && MotionStatus::FALLEN != STANDUP) fallen_at = s;
    std::printf("t %d fallen %d fb_gyro %d rl_gyro %d fb_acc %d rl_acc %d\n", s, (int)MotionStatus::FALLEN,
                MotionStatus::FB_GYRO, MotionStatus::RL_GYRO, MotionStatus::FB_ACCEL, MotionStatus::RL_ACCEL);
    std::fflush(stdout);
  }
  Walking::GetInstance()->Stop();
  for (int i = 0; i < 250 && Walking::GetInstance()->IsRunning(); ++i) usleep(8000);
  std::printf("done: walked %d s, framework's fall flag first at %d s (-1 never)\n", seconds, fallen_at);
  motion_timer->Stop();
  return 0;
}
