#pragma once
// Pixel formats a robot camera delivers, and conversion between them and 8-bit RGB. RGB24 is
// R, G, B per pixel; YUV422 packs two pixels in four bytes (YUYV: Y0 U Y1 V, UYVY: U Y0 V Y1) with
// BT.601 studio-range coefficients (Y 16..235, Cb/Cr 16..240) and the chroma of each pair averaged;
// 8-bit Bayer keeps one colour per pixel, the 2x2 pattern named from the top-left pixel.
// The renderer encodes row by row into shared memory; decoding is for viewing and tests.

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace doppel::camera {

enum class PixelFormat : uint32_t {
  kRgb24 = 0,
  kYuyv = 1,
  kUyvy = 2,
  kBayerRggb = 3,
  kBayerBggr = 4,
  kBayerGrbg = 5,
  kBayerGbrg = 6,
};

inline constexpr PixelFormat kAllPixelFormats[] = {PixelFormat::kRgb24,     PixelFormat::kYuyv,
                                                   PixelFormat::kUyvy,      PixelFormat::kBayerRggb,
                                                   PixelFormat::kBayerBggr, PixelFormat::kBayerGrbg,
                                                   PixelFormat::kBayerGbrg};

std::string_view to_string(PixelFormat format) noexcept;
// Parses "rgb24", "yuyv", "uyvy", "bayer_rggb", "bayer_bggr", "bayer_grbg", "bayer_gbrg";
// throws std::invalid_argument naming the accepted values.
PixelFormat parse_pixel_format(std::string_view name);

bool is_bayer(PixelFormat format) noexcept;
bool is_yuv422(PixelFormat format) noexcept;
// Bytes of one row / one frame. YUV422 needs an even width (Lens and CameraConfig check it).
size_t row_bytes(PixelFormat format, int width_px) noexcept;
size_t frame_bytes(PixelFormat format, int width_px, int height_px) noexcept;

// Which colour a Bayer sensor samples at (x, y): 0 red, 1 green, 2 blue. rt-safe.
int bayer_channel(PixelFormat format, int x, int y) noexcept;

struct YCbCr {
  uint8_t y = 16;    // luma, 16..235
  uint8_t cb = 128;  // blue-difference chroma, 16..240
  uint8_t cr = 128;  // red-difference chroma, 16..240
};
// BT.601 studio range: Y = 16 + (65.481 R + 128.553 G + 24.966 B) / 255, and so on, rounded. rt-safe.
YCbCr rgb_to_ycbcr(uint8_t r, uint8_t g, uint8_t b) noexcept;
// The inverse, clamped to 0..255. rt-safe.
void ycbcr_to_rgb(uint8_t y, uint8_t cb, uint8_t cr, uint8_t* rgb) noexcept;

// Encodes one row of `width_px` RGB24 pixels (row index `y`, which selects the Bayer phase) into
// `out`, which holds row_bytes(format, width_px). rt-safe.
void encode_row(PixelFormat format, int y, const uint8_t* rgb, int width_px, uint8_t* out) noexcept;
// Encodes a whole RGB24 image. rt-safe.
void encode_image(PixelFormat format, const uint8_t* rgb, int width_px, int height_px, uint8_t* out) noexcept;

// Converts a frame to RGB24 for viewing (`rgb` holds 3 * width * height bytes): YUV422 through
// libyuv when built with it (BT.601, as encoded), Bayer by bilinear demosaicing. Not rt-safe.
void decode_to_rgb(PixelFormat format, const uint8_t* data, int width_px, int height_px, uint8_t* rgb);

}  // namespace doppel::camera
