#include "camera/pixel_format.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

#ifdef DOPPEL_HAVE_LIBYUV
#include <libyuv/convert_argb.h>
#include <libyuv/convert_from_argb.h>

#include <vector>
#endif

namespace doppel::camera {
namespace {

// BT.601 studio-range forward coefficients per 8-bit unit (ITU-R BT.601-7, table 3 scaled to 0..255).
// The encoder is ours, not libyuv's: libyuv's ARGBToYUY2/ARGBToUYVY (Debian 0.0~git20230123) use
// 7-bit coefficients and take chroma from the averaged pair, so they give red Y 82 and Cr 239
// where the formula gives 81.48 -> 81 and 240, and miss the rounded formula's Cb on about half of
// all pixel pairs (checked on 200 000 random pairs). The tests hold the formula's values.
constexpr double kYr = 65.481 / 255.0, kYg = 128.553 / 255.0, kYb = 24.966 / 255.0;
constexpr double kCbr = -37.797 / 255.0, kCbg = -74.203 / 255.0, kCbb = 112.0 / 255.0;
constexpr double kCrr = 112.0 / 255.0, kCrg = -93.786 / 255.0, kCrb = -18.214 / 255.0;

// Contributions of each 8-bit channel value in 16.16 fixed point, so a pixel costs 9 table reads.
struct Tables {
  std::array<int32_t, 256> yr, yg, yb, cbr, cbg, cbb, crr, crg, crb;
  Tables() {
    for (int v = 0; v < 256; ++v) {
      auto fx = [v](double k) { return static_cast<int32_t>(std::lround(k * v * 65536.0)); };
      yr[v] = fx(kYr);
      yg[v] = fx(kYg);
      yb[v] = fx(kYb);
      cbr[v] = fx(kCbr);
      cbg[v] = fx(kCbg);
      cbb[v] = fx(kCbb);
      crr[v] = fx(kCrr);
      crg[v] = fx(kCrg);
      crb[v] = fx(kCrb);
    }
  }
};
const Tables kTables;

inline uint8_t clamp_u8(int32_t v) noexcept { return static_cast<uint8_t>(std::clamp(v, 0, 255)); }

inline uint8_t luma(const uint8_t* p) noexcept {
  const Tables& t = kTables;
  return clamp_u8((t.yr[p[0]] + t.yg[p[1]] + t.yb[p[2]] + (16 << 16) + (1 << 15)) >> 16);
}

// Chroma of the average of two pixels, rounded: the two contributions are summed and halved.
inline void pair_chroma(const uint8_t* p0, const uint8_t* p1, uint8_t* cb, uint8_t* cr) noexcept {
  const Tables& t = kTables;
  const int32_t scb = t.cbr[p0[0]] + t.cbg[p0[1]] + t.cbb[p0[2]] + t.cbr[p1[0]] + t.cbg[p1[1]] + t.cbb[p1[2]];
  const int32_t scr = t.crr[p0[0]] + t.crg[p0[1]] + t.crb[p0[2]] + t.crr[p1[0]] + t.crg[p1[1]] + t.crb[p1[2]];
  *cb = clamp_u8((scb + (256 << 16) + (1 << 16)) >> 17);
  *cr = clamp_u8((scr + (256 << 16) + (1 << 16)) >> 17);
}

void demosaic_bilinear(PixelFormat format, const uint8_t* data, int w, int h, uint8_t* rgb) {
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      int sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      const int own = bayer_channel(format, x, y);
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= h) continue;
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx;
          if (xx < 0 || xx >= w) continue;
          const int c = bayer_channel(format, xx, yy);
          // Green at a green site: only the site itself (its diagonal greens would blur it).
          if (c == own && (dx != 0 || dy != 0)) continue;
          sum[c] += data[static_cast<size_t>(yy) * w + xx];
          ++count[c];
        }
      }
      uint8_t* out = rgb + 3 * (static_cast<size_t>(y) * w + x);
      for (int c = 0; c < 3; ++c) {
        out[c] = count[c] > 0 ? static_cast<uint8_t>((sum[c] + count[c] / 2) / count[c]) : 0;
      }
    }
  }
}

}  // namespace

std::string_view to_string(PixelFormat format) noexcept {
  switch (format) {
    case PixelFormat::kRgb24: return "rgb24";
    case PixelFormat::kYuyv: return "yuyv";
    case PixelFormat::kUyvy: return "uyvy";
    case PixelFormat::kBayerRggb: return "bayer_rggb";
    case PixelFormat::kBayerBggr: return "bayer_bggr";
    case PixelFormat::kBayerGrbg: return "bayer_grbg";
    case PixelFormat::kBayerGbrg: return "bayer_gbrg";
  }
  return "unknown";
}

PixelFormat parse_pixel_format(std::string_view name) {
  for (PixelFormat f : kAllPixelFormats) {
    if (to_string(f) == name) return f;
  }
  throw std::invalid_argument("unknown pixel format '" + std::string(name) +
                              "' (rgb24, yuyv, uyvy, bayer_rggb, bayer_bggr, bayer_grbg, bayer_gbrg)");
}

bool is_bayer(PixelFormat format) noexcept {
  return format == PixelFormat::kBayerRggb || format == PixelFormat::kBayerBggr ||
         format == PixelFormat::kBayerGrbg || format == PixelFormat::kBayerGbrg;
}

bool is_yuv422(PixelFormat format) noexcept { return format == PixelFormat::kYuyv || format == PixelFormat::kUyvy; }

size_t row_bytes(PixelFormat format, int width_px) noexcept {
  const size_t w = width_px > 0 ? static_cast<size_t>(width_px) : 0;
  if (format == PixelFormat::kRgb24) return 3 * w;
  if (is_yuv422(format)) return 2 * w;
  return w;
}

size_t frame_bytes(PixelFormat format, int width_px, int height_px) noexcept {
  return row_bytes(format, width_px) * static_cast<size_t>(height_px > 0 ? height_px : 0);
}

int bayer_channel(PixelFormat format, int x, int y) noexcept {
  // Pattern as a 2x2 table read left to right, top to bottom: R=0, G=1, B=2.
  static constexpr int kRggb[4] = {0, 1, 1, 2};
  static constexpr int kBggr[4] = {2, 1, 1, 0};
  static constexpr int kGrbg[4] = {1, 0, 2, 1};
  static constexpr int kGbrg[4] = {1, 2, 0, 1};
  const int i = ((y & 1) << 1) | (x & 1);
  switch (format) {
    case PixelFormat::kBayerRggb: return kRggb[i];
    case PixelFormat::kBayerBggr: return kBggr[i];
    case PixelFormat::kBayerGrbg: return kGrbg[i];
    case PixelFormat::kBayerGbrg: return kGbrg[i];
    default: return 1;
  }
}

YCbCr rgb_to_ycbcr(uint8_t r, uint8_t g, uint8_t b) noexcept {
  const uint8_t p[3] = {r, g, b};
  YCbCr out;
  out.y = luma(p);
  pair_chroma(p, p, &out.cb, &out.cr);
  return out;
}

void ycbcr_to_rgb(uint8_t y, uint8_t cb, uint8_t cr, uint8_t* rgb) noexcept {
  // Inverse of the BT.601 studio-range matrix (255/219 on luma, 255/224 on chroma).
  const double yy = 255.0 / 219.0 * (y - 16.0);
  const double u = cb - 128.0;
  const double v = cr - 128.0;
  const double r = yy + 255.0 / 224.0 * 1.402 * v;
  const double g = yy - 255.0 / 224.0 * (1.772 * 0.114 / 0.587) * u - 255.0 / 224.0 * (1.402 * 0.299 / 0.587) * v;
  const double b = yy + 255.0 / 224.0 * 1.772 * u;
  rgb[0] = clamp_u8(static_cast<int32_t>(std::lround(r)));
  rgb[1] = clamp_u8(static_cast<int32_t>(std::lround(g)));
  rgb[2] = clamp_u8(static_cast<int32_t>(std::lround(b)));
}

void encode_row(PixelFormat format, int y, const uint8_t* rgb, int width_px, uint8_t* out) noexcept {
  switch (format) {
    case PixelFormat::kRgb24:
      std::copy(rgb, rgb + 3 * static_cast<size_t>(width_px), out);
      return;
    case PixelFormat::kYuyv:
    case PixelFormat::kUyvy: {
      const bool yuyv = format == PixelFormat::kYuyv;
      for (int x = 0; x + 1 < width_px; x += 2) {
        const uint8_t* p0 = rgb + 3 * x;
        const uint8_t* p1 = p0 + 3;
        uint8_t cb = 0;
        uint8_t cr = 0;
        pair_chroma(p0, p1, &cb, &cr);
        uint8_t* o = out + 2 * x;
        if (yuyv) {
          o[0] = luma(p0);
          o[1] = cb;
          o[2] = luma(p1);
          o[3] = cr;
        } else {
          o[0] = cb;
          o[1] = luma(p0);
          o[2] = cr;
          o[3] = luma(p1);
        }
      }
      return;
    }
    default: {
      // Even and odd columns of this row sample fixed channels.
      const int c0 = bayer_channel(format, 0, y);
      const int c1 = bayer_channel(format, 1, y);
      int x = 0;
      for (; x + 1 < width_px; x += 2) {
        out[x] = rgb[3 * x + c0];
        out[x + 1] = rgb[3 * x + 3 + c1];
      }
      if (x < width_px) out[x] = rgb[3 * x + c0];
      return;
    }
  }
}

void encode_image(PixelFormat format, const uint8_t* rgb, int width_px, int height_px, uint8_t* out) noexcept {
  const size_t in_row = 3 * static_cast<size_t>(width_px);
  const size_t out_row = row_bytes(format, width_px);
  for (int y = 0; y < height_px; ++y) encode_row(format, y, rgb + y * in_row, width_px, out + y * out_row);
}

void decode_to_rgb(PixelFormat format, const uint8_t* data, int width_px, int height_px, uint8_t* rgb) {
  const size_t n = static_cast<size_t>(width_px) * static_cast<size_t>(height_px);
  if (format == PixelFormat::kRgb24) {
    std::copy(data, data + 3 * n, rgb);
    return;
  }
  if (is_yuv422(format)) {
#ifdef DOPPEL_HAVE_LIBYUV
    // libyuv's ARGB is B, G, R, A in memory and its RAW is R, G, B: the order RGB24 means here.
    std::vector<uint8_t> argb(4 * n);
    const int stride = static_cast<int>(row_bytes(format, width_px));
    const int rc = format == PixelFormat::kYuyv
                       ? libyuv::YUY2ToARGB(data, stride, argb.data(), 4 * width_px, width_px, height_px)
                       : libyuv::UYVYToARGB(data, stride, argb.data(), 4 * width_px, width_px, height_px);
    if (rc == 0 && libyuv::ARGBToRAW(argb.data(), 4 * width_px, rgb, 3 * width_px, width_px, height_px) == 0) return;
#endif
    const bool yuyv = format == PixelFormat::kYuyv;
    for (int y = 0; y < height_px; ++y) {
      const uint8_t* row = data + static_cast<size_t>(y) * row_bytes(format, width_px);
      for (int x = 0; x + 1 < width_px; x += 2) {
        const uint8_t* q = row + 2 * x;
        const uint8_t y0 = yuyv ? q[0] : q[1];
        const uint8_t y1 = yuyv ? q[2] : q[3];
        const uint8_t cb = yuyv ? q[1] : q[0];
        const uint8_t cr = yuyv ? q[3] : q[2];
        uint8_t* o = rgb + 3 * (static_cast<size_t>(y) * width_px + x);
        ycbcr_to_rgb(y0, cb, cr, o);
        ycbcr_to_rgb(y1, cb, cr, o + 3);
      }
    }
    return;
  }
  demosaic_bilinear(format, data, width_px, height_px, rgb);
}

}  // namespace doppel::camera
