// The one SYNC WRITE with which Linux/project/tutorial/ball_following hands the body to Walking:
// every joint's goal is Walking's standing pose, its moving speed a quarter of the distance (at
// least 8). start.cpp and walk.cpp send it as that tutorial does; written against the framework's
// API only.
#pragma once

#include "LinuxDARwIn.h"

inline void sync_write_walking_pose(Robot::CM730& cm730) {
  using namespace Robot;
  int n = 0;
  int param[JointData::NUMBER_OF_JOINTS * 5];
  for (int id = JointData::ID_R_SHOULDER_PITCH; id < JointData::NUMBER_OF_JOINTS; id++) {
    const int start = MotionStatus::m_CurrentJoints.GetValue(id);
    const int goal = Walking::GetInstance()->m_Joint.GetValue(id);
    int distance = start > goal ? start - goal : goal - start;
    distance >>= 2;
    if (distance < 8) distance = 8;
    param[n++] = id;
    param[n++] = CM730::GetLowByte(goal);
    param[n++] = CM730::GetHighByte(goal);
    param[n++] = CM730::GetLowByte(distance);
    param[n++] = CM730::GetHighByte(distance);
  }
  cm730.SyncWrite(MX28::P_GOAL_POSITION_L, 5, JointData::NUMBER_OF_JOINTS - 1, param);
}
