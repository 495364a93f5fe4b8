// The DARwIn-OP framework's start-up as Linux/project/tutorial/ball_following does it, then a
// verdict: did the BULK READ that MotionManager's timer thread built (CM730::MakeBulkReadPacket,
// in its first cycle) take in the CM-730 and both FSR boards, do they answer, and did the gyro
// calibrate. Our own program: it only calls the framework's public API and is compiled by
// scripts/check-darwin-framework against the user's copy of the framework (GPL, not vendored).
//
// usage: start [PORT] [CONFIG_INI] [SECONDS]   (defaults /dev/ttyUSB0, Data/config.ini, 5)
// exit: 0 started, 1 not started (the line says why), 2 MotionManager::Initialize failed.
// Prints one line: "start: bulk_read cm730=<in|out>/<answered|silent> fsr_l=... fsr_r=...
// gyro_calibration=<status> joints=<n>/20 verdict=<started|NOT-STARTED>".

#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "LinuxDARwIn.h"
#include "walking_pose.h"

using namespace Robot;

namespace {

double now_s() {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

void sleep_ms(int ms) {
  struct timespec t = {ms / 1000, (ms % 1000) * 1000000L};
  nanosleep(&t, NULL);
}

// The device is in the BULK READ packet: BulkRead() sets length and start address for exactly
// the IDs of its packet (they stay 0 for the others).
bool in_bulk_read(CM730& cm730, int id) { return cm730.m_BulkReadData[id].length > 0; }

const char* state(CM730& cm730, int id, const int answered[]) {
  if (!in_bulk_read(cm730, id)) return "out";
  return answered[id] > 0 ? "in/answered" : "in/silent";
}

}  // namespace

int main(int argc, char** argv) {
  const char* port = argc > 1 ? argv[1] : "/dev/ttyUSB0";
  const char* ini_path = argc > 2 ? argv[2] : "Data/config.ini";
  const double seconds = argc > 3 ? atof(argv[3]) : 5.0;

  minIni* ini = new minIni(ini_path);

  LinuxCM730 linux_cm730(port);
  CM730 cm730(&linux_cm730);
  if (MotionManager::GetInstance()->Initialize(&cm730) == false) {
    printf("start: MotionManager::Initialize failed (port %s) verdict=NOT-STARTED\n", port);
    return 2;
  }
  MotionManager::GetInstance()->LoadINISettings(ini);
  Walking::GetInstance()->LoadINISettings(ini);
  MotionManager::GetInstance()->AddModule((MotionModule*)Walking::GetInstance());
  LinuxMotionTimer* motion_timer = new LinuxMotionTimer(MotionManager::GetInstance());
  motion_timer->Start();

  sync_write_walking_pose(cm730);

  Walking::GetInstance()->m_Joint.SetEnableBodyWithoutHead(true, true);
  MotionManager::GetInstance()->SetEnable(true);

  // Watch the cycles: a device counts as answering when its block came back without error in
  // at least one sampled cycle (error is -1 until a cycle parses its status).
  const int ids[3] = {CM730::ID_CM, FSR::ID_L_FSR, FSR::ID_R_FSR};
  int answered[CM730::ID_BROADCAST] = {0};
  const double end = now_s() + seconds;
  while (now_s() < end) {
    for (int k = 0; k < 3; k++) {
      if (in_bulk_read(cm730, ids[k]) && cm730.m_BulkReadData[ids[k]].error == 0) answered[ids[k]]++;
    }
    if (MotionManager::GetInstance()->GetCalibrationStatus() == 1 && answered[CM730::ID_CM] > 0 &&
        answered[FSR::ID_L_FSR] > 0 && answered[FSR::ID_R_FSR] > 0) {
      break;
    }
    sleep_ms(4);
  }
  const int calibration = MotionManager::GetInstance()->GetCalibrationStatus();
  motion_timer->Stop();

  int joints = 0;
  for (int id = JointData::ID_R_SHOULDER_PITCH; id < JointData::NUMBER_OF_JOINTS; id++) {
    if (MotionStatus::m_CurrentJoints.GetEnable(id)) joints++;
  }
  const bool started = calibration == 1 && answered[CM730::ID_CM] > 0 && answered[FSR::ID_L_FSR] > 0 &&
                       answered[FSR::ID_R_FSR] > 0;
  printf("start: bulk_read cm730=%s fsr_l=%s fsr_r=%s gyro_calibration=%d joints=%d/%d verdict=%s\n",
         state(cm730, CM730::ID_CM, answered), state(cm730, FSR::ID_L_FSR, answered),
         state(cm730, FSR::ID_R_FSR, answered), calibration, joints, JointData::NUMBER_OF_JOINTS - 1,
         started ? "started" : "NOT-STARTED");
  return started ? 0 : 1;
}
