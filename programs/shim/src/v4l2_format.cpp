#include "shim/v4l2_format.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>

namespace doppel::shim {
namespace {

bool is_yuv422(uint32_t source_format) noexcept {
  return source_format == static_cast<uint32_t>(SourceFormat::kYuyv) ||
         source_format == static_cast<uint32_t>(SourceFormat::kUyvy);
}

uint32_t bytes_per_pixel_row(uint32_t fourcc, int width) noexcept {
  switch (fourcc) {
    case V4L2_PIX_FMT_RGB24:
      return static_cast<uint32_t>(width) * 3;
    case V4L2_PIX_FMT_YUYV:
    case V4L2_PIX_FMT_UYVY:
      return static_cast<uint32_t>(width) * 2;
    default:
      return static_cast<uint32_t>(width);
  }
}

// The control table, in id order (QUERYCTRL with V4L2_CTRL_FLAG_NEXT_CTRL walks it in this order).
// Ranges: 8-bit brightness, contrast, saturation and gain as UVC webcams give them; exposure in
// 100 us units up to one frame period; white balance 2800..6500 K.
constexpr int kControlCount = 10;

int32_t default_exposure(double fps) noexcept { return std::max(1, static_cast<int32_t>(std::lround(1e4 / (2.0 * fps)))); }
int32_t max_exposure(double fps) noexcept { return std::max(1, static_cast<int32_t>(std::lround(1e4 / fps))); }

// Tanner Helland, "How to Convert Temperature (K) to RGB" (2012): a fit to the black-body colours
// of Mitchell Charity's table, in 0..255 per channel.
void kelvin_rgb(double kelvin, double rgb[3]) noexcept {
  const double t = kelvin / 100.0;
  rgb[0] = t <= 66 ? 255.0 : 329.698727446 * std::pow(t - 60, -0.1332047592);
  rgb[1] = t <= 66 ? 99.4708025861 * std::log(t) - 161.1195681661 : 288.1221695283 * std::pow(t - 60, -0.0755148492);
  rgb[2] = t >= 66 ? 255.0 : (t <= 19 ? 0.0 : 138.5177312231 * std::log(t - 10) - 305.0447927307);
  for (int c = 0; c < 3; ++c) rgb[c] = std::clamp(rgb[c], 1.0, 255.0);
}

}  // namespace

uint32_t fourcc_of(uint32_t source_format) noexcept {
  switch (static_cast<SourceFormat>(source_format)) {
    case SourceFormat::kRgb24: return V4L2_PIX_FMT_RGB24;
    case SourceFormat::kYuyv: return V4L2_PIX_FMT_YUYV;
    case SourceFormat::kUyvy: return V4L2_PIX_FMT_UYVY;
    case SourceFormat::kBayerRggb: return V4L2_PIX_FMT_SRGGB8;
    case SourceFormat::kBayerBggr: return V4L2_PIX_FMT_SBGGR8;
    case SourceFormat::kBayerGrbg: return V4L2_PIX_FMT_SGRBG8;
    case SourceFormat::kBayerGbrg: return V4L2_PIX_FMT_SGBRG8;
  }
  return 0;
}

int format_count(const SourceCamera& camera) noexcept {
  return camera.format == static_cast<uint32_t>(SourceFormat::kUyvy) ? 2 : 1;
}

uint32_t format_at(const SourceCamera& camera, int index) noexcept {
  if (index == 0) return fourcc_of(camera.format);
  if (index == 1 && format_count(camera) == 2) return V4L2_PIX_FMT_YUYV;
  return 0;
}

bool format_offered(const SourceCamera& camera, uint32_t fourcc) noexcept {
  for (int i = 0; i < format_count(camera); ++i) {
    if (format_at(camera, i) == fourcc) return true;
  }
  return false;
}

int size_count(const SourceCamera& camera, uint32_t fourcc) noexcept {
  if (!format_offered(camera, fourcc)) return 0;
  if (!is_yuv422(camera.format)) return 1;
  int count = 1;
  for (int bin = 2; bin <= 4; bin *= 2) {
    if (camera.width % (2 * bin) == 0 && camera.height % bin == 0) count++;
  }
  return count;
}

Mode mode_at(const SourceCamera& camera, uint32_t fourcc, int index) noexcept {
  Mode mode;
  if (index < 0 || index >= size_count(camera, fourcc)) return mode;
  mode.fourcc = fourcc;
  mode.bin = 1 << index;
  mode.width = camera.width / mode.bin;
  mode.height = camera.height / mode.bin;
  mode.bytesperline = bytes_per_pixel_row(fourcc, mode.width);
  mode.sizeimage = mode.bytesperline * static_cast<uint32_t>(mode.height);
  return mode;
}

Mode nearest_mode(const SourceCamera& camera, uint32_t fourcc, int width, int height) noexcept {
  if (!format_offered(camera, fourcc)) fourcc = format_at(camera, 0);
  Mode best = mode_at(camera, fourcc, 0);
  long best_distance = -1;
  for (int i = 0; i < size_count(camera, fourcc); ++i) {
    const Mode m = mode_at(camera, fourcc, i);
    const long distance = std::labs(static_cast<long>(m.width) - width) + std::labs(static_cast<long>(m.height) - height);
    if (best_distance < 0 || distance < best_distance) {
      best = m;
      best_distance = distance;
    }
  }
  return best;
}

v4l2_fract frame_interval(double fps) noexcept {
  v4l2_fract f{1000, static_cast<uint32_t>(std::max(1L, std::lround(fps * 1000.0)))};
  uint32_t a = f.numerator;
  uint32_t b = f.denominator;
  while (b != 0) {
    const uint32_t r = a % b;
    a = b;
    b = r;
  }
  f.numerator /= a;
  f.denominator /= a;
  return f;
}

int control_count() noexcept { return kControlCount; }

ControlInfo control_at(int index, double fps) noexcept {
  const ControlInfo table[kControlCount] = {
      {V4L2_CID_USER_CLASS, V4L2_CTRL_TYPE_CTRL_CLASS, "User Controls", 0, 0, 0, 0},
      {V4L2_CID_BRIGHTNESS, V4L2_CTRL_TYPE_INTEGER, "Brightness", 0, 255, 1, 128},
      {V4L2_CID_CONTRAST, V4L2_CTRL_TYPE_INTEGER, "Contrast", 0, 255, 1, 128},
      {V4L2_CID_SATURATION, V4L2_CTRL_TYPE_INTEGER, "Saturation", 0, 255, 1, 128},
      {V4L2_CID_AUTO_WHITE_BALANCE, V4L2_CTRL_TYPE_BOOLEAN, "White Balance, Automatic", 0, 1, 1, 1},
      {V4L2_CID_GAIN, V4L2_CTRL_TYPE_INTEGER, "Gain", 0, 255, 1, 0},
      {V4L2_CID_WHITE_BALANCE_TEMPERATURE, V4L2_CTRL_TYPE_INTEGER, "White Balance Temperature", 2800, 6500, 1, 6500},
      {V4L2_CID_CAMERA_CLASS, V4L2_CTRL_TYPE_CTRL_CLASS, "Camera Controls", 0, 0, 0, 0},
      {V4L2_CID_EXPOSURE_AUTO, V4L2_CTRL_TYPE_MENU, "Auto Exposure", V4L2_EXPOSURE_MANUAL,
       V4L2_EXPOSURE_APERTURE_PRIORITY, 1, V4L2_EXPOSURE_APERTURE_PRIORITY},
      {V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER, "Exposure Time, Absolute", 1, max_exposure(fps), 1,
       default_exposure(fps)},
  };
  return index >= 0 && index < kControlCount ? table[index] : ControlInfo{0, 0, "", 0, 0, 0, 0};
}

int control_index(uint32_t id) noexcept {
  for (int i = 0; i < kControlCount; ++i) {
    if (control_at(i, 30.0).id == id) return i;
  }
  return -1;
}

const char* exposure_menu_name(int32_t value) noexcept {
  // uvcvideo offers manual and aperture priority (auto time, fixed iris); names from v4l2-ctrls-defs.c.
  if (value == V4L2_EXPOSURE_MANUAL) return "Manual Mode";
  if (value == V4L2_EXPOSURE_APERTURE_PRIORITY) return "Aperture Priority Mode";
  return nullptr;
}

ControlValues default_controls(double fps) noexcept {
  ControlValues v;
  v.exposure_absolute = default_exposure(fps);
  return v;
}

ToneCurves tone_curves(const ControlValues& values, double fps, uint32_t source_format) noexcept {
  ToneCurves curves;
  const bool yuv = is_yuv422(source_format);
  const double lo = yuv ? 16.0 : 0.0;
  const double hi = yuv ? 235.0 : 255.0;
  const double range = hi - lo;
  const bool manual = values.exposure_auto == V4L2_EXPOSURE_MANUAL;
  const double exposure = manual ? static_cast<double>(values.exposure_absolute) / default_exposure(fps) : 1.0;
  const double gain = 1.0 + values.gain / 32.0;
  curves.identity = values.brightness == 128 && values.contrast == 128 && values.saturation == 128 && values.gain == 0 &&
                    (!manual || values.exposure_absolute == default_exposure(fps));
  for (int i = 0; i < 256; ++i) {
    double v = (i - lo) * exposure * gain;
    v = (v - range / 2) * values.contrast / 128.0 + range / 2;
    v += (values.brightness - 128) * range / 255.0;
    curves.luma[i] = static_cast<uint8_t>(std::clamp(std::lround(v + lo), yuv ? 16L : 0L, yuv ? 235L : 255L));
    const double c = 128.0 + (i - 128.0) * values.saturation / 128.0;
    curves.chroma[i] = yuv ? static_cast<uint8_t>(std::clamp(std::lround(c), 16L, 240L)) : static_cast<uint8_t>(i);
  }
  if (curves.identity) {
    for (int i = 0; i < 256; ++i) curves.luma[i] = curves.chroma[i] = static_cast<uint8_t>(i);
  }
  return curves;
}

void white_balance_gains(int32_t kelvin, double gains[3]) noexcept {
  double reference[3];
  double light[3];
  kelvin_rgb(6500.0, reference);
  kelvin_rgb(static_cast<double>(kelvin), light);
  for (int c = 0; c < 3; ++c) gains[c] = reference[c] / light[c];
  const double green = gains[1];
  for (int c = 0; c < 3; ++c) gains[c] = std::clamp(gains[c] / green, 0.001, 100.0);
}

size_t convert_frame(const SourceCamera& camera, const uint8_t* source, uint32_t source_stride, const Mode& mode,
                     const ToneCurves& curves, uint8_t* out) noexcept {
  const uint32_t native = fourcc_of(camera.format);
  if (mode.bin == 1 && mode.fourcc == native) {
    for (int y = 0; y < mode.height; ++y) {
      const uint8_t* in = source + static_cast<size_t>(y) * source_stride;
      uint8_t* row = out + static_cast<size_t>(y) * mode.bytesperline;
      if (curves.identity) {
        std::memcpy(row, in, mode.bytesperline);
      } else if (native == V4L2_PIX_FMT_YUYV || native == V4L2_PIX_FMT_UYVY) {
        const int luma_phase = native == V4L2_PIX_FMT_YUYV ? 0 : 1;
        for (uint32_t i = 0; i < mode.bytesperline; ++i) {
          row[i] = (static_cast<int>(i & 1) == luma_phase) ? curves.luma[in[i]] : curves.chroma[in[i]];
        }
      } else {
        for (uint32_t i = 0; i < mode.bytesperline; ++i) row[i] = curves.luma[in[i]];
      }
    }
    return mode.sizeimage;
  }
  // YUV 4:2:2 binned by mode.bin and/or reordered: byte offsets of Y0, U, Y1, V in a pixel pair.
  const bool in_yuyv = native == V4L2_PIX_FMT_YUYV;
  const int iy0 = in_yuyv ? 0 : 1, iu = in_yuyv ? 1 : 0, iy1 = in_yuyv ? 2 : 3, iv = in_yuyv ? 3 : 2;
  const bool out_yuyv = mode.fourcc == V4L2_PIX_FMT_YUYV;
  const int oy0 = out_yuyv ? 0 : 1, ou = out_yuyv ? 1 : 0, oy1 = out_yuyv ? 2 : 3, ov = out_yuyv ? 3 : 2;
  const int b = mode.bin;
  const int luma_n = b * b;
  for (int y = 0; y < mode.height; ++y) {
    uint8_t* row = out + static_cast<size_t>(y) * mode.bytesperline;
    for (int p = 0; p < mode.width / 2; ++p) {
      int y0 = 0, y1 = 0, u = 0, v = 0;
      for (int r = 0; r < b; ++r) {
        const uint8_t* in = source + static_cast<size_t>(y * b + r) * source_stride;
        // Output pixel 2p covers source pixels [2p*b, 2p*b+b): b/2 pairs (b even) or one pixel (b = 1).
        for (int k = 0; k < 2 * b; ++k) {
          const int x = 2 * p * b + k;
          const uint8_t* pair = in + 4 * (x / 2);
          const int luma = (x & 1) == 0 ? pair[iy0] : pair[iy1];
          (k < b ? y0 : y1) += luma;
          if ((x & 1) == 0) {
            u += pair[iu];
            v += pair[iv];
          }
        }
      }
      const int chroma_n = b * b;  // pairs summed: b rows x b pairs
      uint8_t* o = row + 4 * p;
      o[oy0] = curves.luma[(y0 + luma_n / 2) / luma_n];
      o[oy1] = curves.luma[(y1 + luma_n / 2) / luma_n];
      o[ou] = curves.chroma[(u + chroma_n / 2) / chroma_n];
      o[ov] = curves.chroma[(v + chroma_n / 2) / chroma_n];
    }
  }
  return mode.sizeimage;
}

}  // namespace doppel::shim
