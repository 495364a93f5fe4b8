// The DARwIn-OP framework's vision front end as its tutorials use it: LinuxCamera on /dev/video0
// with the [Camera] settings of a config.ini, then ColorFinder (its [Find Color] section) on each
// frame's HSV image. Our own program: it only calls the framework's public API and is compiled by
// scripts/check-darwin-framework against the user's copy of the framework (GPL, not vendored).
//
// usage: color_probe CONFIG_INI FRAMES
// Prints "frame N: x X y Y" per frame (ColorFinder's centre in the framework's image, which
// LinuxCamera flips horizontally and vertically; -1 -1 when nothing matched) and a summary
// "probe: found F of N, mean x X y Y". Exit 0 when something was found in every frame, else 1.

#include <cstdio>
#include <cstdlib>

#include "LinuxDARwIn.h"

using namespace Robot;

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s CONFIG_INI FRAMES\n", argv[0]);
    return 2;
  }
  const int frames = std::atoi(argv[2]);
  minIni* ini = new minIni(argv[1]);
  LinuxCamera::GetInstance()->Initialize(0);
  LinuxCamera::GetInstance()->LoadINISettings(ini);
  ColorFinder* finder = new ColorFinder();
  finder->LoadINISettings(ini);

  int found = 0;
  double sum_x = 0.0, sum_y = 0.0;
  for (int i = 0; i < frames; ++i) {
    LinuxCamera::GetInstance()->CaptureFrame();
    const Point2D pos = finder->GetPosition(LinuxCamera::GetInstance()->fbuffer->m_HSVFrame);
    std::printf("frame %d: x %.1f y %.1f\n", i, pos.X, pos.Y);
    if (pos.X >= 0.0 && pos.Y >= 0.0) {
      ++found;
      sum_x += pos.X;
      sum_y += pos.Y;
    }
  }
  if (found > 0) {
    std::printf("probe: found %d of %d, mean x %.1f y %.1f\n", found, frames, sum_x / found, sum_y / found);
  } else {
    std::printf("probe: found 0 of %d\n", frames);
  }
  return found == frames ? 0 : 1;
}
