#pragma once
// What Doppel's V4L2 capture device (libdoppel_v4l2.so, docs/camera.md "V4L2") offers for one camera
// and how a frame becomes the program's image, as pure functions so they are testable without the
// preload library: the pixel formats and sizes (the camera's own, and 2x2 / 4x4 binned for YUV 4:2:2,
// as sensors bin), the nearest size a driver picks (v4l2_find_nearest_size: least |dw| + |dh|), the
// controls and their mapping onto the image, and the copy from the shared-memory frame into the
// program's buffer (one pass: binning and the control curves are applied while copying).

#include <linux/videodev2.h>

#include <cstddef>
#include <cstdint>

namespace doppel::shim {

// Doppel's camera::PixelFormat values (camera/pixel_format.h), kept here as numbers so that this
// header needs no camera library.
enum class SourceFormat : uint32_t { kRgb24 = 0, kYuyv = 1, kUyvy = 2, kBayerRggb = 3, kBayerBggr = 4, kBayerGrbg = 5, kBayerGbrg = 6 };

// The V4L2 fourcc of a Doppel pixel format (V4L2_PIX_FMT_*), 0 for an unknown value.
uint32_t fourcc_of(uint32_t source_format) noexcept;

struct Mode {
  uint32_t fourcc = 0;
  int width = 0;
  int height = 0;
  int bin = 1;  // source pixels per output pixel along each axis
  uint32_t bytesperline = 0;
  uint32_t sizeimage = 0;
};

// The camera a device serves: its native format, size and rate.
struct SourceCamera {
  uint32_t format = 0;  // SourceFormat
  int width = 0;
  int height = 0;
  double fps = 0.0;
};

// Formats offered, in ENUM_FMT order: the camera's own, then YUYV when the camera renders UYVY.
int format_count(const SourceCamera& camera) noexcept;
uint32_t format_at(const SourceCamera& camera, int index) noexcept;
bool format_offered(const SourceCamera& camera, uint32_t fourcc) noexcept;
// Sizes of `fourcc` in ENUM_FRAMESIZES order (bin 1, 2, 4 as far as they give whole, even sizes).
int size_count(const SourceCamera& camera, uint32_t fourcc) noexcept;
Mode mode_at(const SourceCamera& camera, uint32_t fourcc, int index) noexcept;
// TRY_FMT: the requested format if offered (else the camera's own) at the nearest size.
Mode nearest_mode(const SourceCamera& camera, uint32_t fourcc, int width, int height) noexcept;
// The frame interval (seconds = numerator / denominator) of the camera's rate.
v4l2_fract frame_interval(double fps) noexcept;

// Controls (V4L2_CID_*) and their ranges.
struct ControlInfo {
  uint32_t id;
  uint32_t type;  // V4L2_CTRL_TYPE_*
  const char* name;
  int32_t minimum;
  int32_t maximum;
  int32_t step;
  int32_t default_value;
};
// The controls in id order (class controls included), for a camera of `fps`.
int control_count() noexcept;
ControlInfo control_at(int index, double fps) noexcept;
int control_index(uint32_t id) noexcept;  // -1 when not a control of the device
// Menu item names of V4L2_CID_EXPOSURE_AUTO (nullptr for a skipped item).
const char* exposure_menu_name(int32_t value) noexcept;

struct ControlValues {
  int32_t brightness = 128;
  int32_t contrast = 128;
  int32_t saturation = 128;
  int32_t gain = 0;
  int32_t exposure_auto = V4L2_EXPOSURE_APERTURE_PRIORITY;
  int32_t exposure_absolute = 0;  // 100 us units; set to the default for the camera's rate
  int32_t white_balance_auto = 1;
  int32_t white_balance_temperature = 6500;
};
ControlValues default_controls(double fps) noexcept;

// The byte curves the controls give: `luma` for Y (and every byte of RGB and Bayer), `chroma` for
// Cb and Cr. Identity when every control is at its default (`identity` true).
struct ToneCurves {
  uint8_t luma[256];
  uint8_t chroma[256];
  bool identity = true;
};
ToneCurves tone_curves(const ControlValues& values, double fps, uint32_t source_format) noexcept;

// White-balance gains (red, green, blue; green 1) a camera set to `kelvin` applies to a scene lit
// by D65 (which the renderer's colours are): the inverse of the illuminant colour at `kelvin`
// relative to 6500 K (Tanner Helland's black-body fit, 2012).
void white_balance_gains(int32_t kelvin, double gains[3]) noexcept;

// Copies one source frame (`source`, rows of `source_stride` bytes, the camera's format and size)
// into `out` as `mode`, applying `curves`. Returns the bytes written (mode.sizeimage). rt-safe.
size_t convert_frame(const SourceCamera& camera, const uint8_t* source, uint32_t source_stride, const Mode& mode,
                     const ToneCurves& curves, uint8_t* out) noexcept;

}  // namespace doppel::shim
