#include "camera/pixel_format.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace doppel::camera {
namespace {

// Expected values are BT.601 studio range computed by hand:
// Y = 16 + (65.481 R + 128.553 G + 24.966 B) / 255, Cb = 128 + (-37.797 R - 74.203 G + 112 B) / 255,
// Cr = 128 + (112 R - 93.786 G - 18.214 B) / 255, rounded to the nearest integer.
TEST(PixelFormatTest, Bt601ConversionOfPrimariesMatchesHandComputedValues) {
  struct Case {
    uint8_t r, g, b, y, cb, cr;
  };
  const Case cases[] = {
      {255, 255, 255, 235, 128, 128},  // white
      {0, 0, 0, 16, 128, 128},         // black
      {255, 0, 0, 81, 90, 240},        // 81.481, 90.203, 240
      {0, 255, 0, 145, 54, 34},        // 144.553, 53.797, 34.214
      {0, 0, 255, 41, 240, 110},       // 40.966, 240, 109.786
  };
  for (const Case& c : cases) {
    const YCbCr sut = rgb_to_ycbcr(c.r, c.g, c.b);
    EXPECT_EQ(sut.y, c.y) << int(c.r) << "," << int(c.g) << "," << int(c.b);
    EXPECT_EQ(sut.cb, c.cb);
    EXPECT_EQ(sut.cr, c.cr);
  }
}

TEST(PixelFormatTest, YuvToRgbInvertsTheBt601Matrix) {
  uint8_t rgb[3];
  ycbcr_to_rgb(235, 128, 128, rgb);
  EXPECT_EQ(rgb[0], 255);
  EXPECT_EQ(rgb[1], 255);
  EXPECT_EQ(rgb[2], 255);
  ycbcr_to_rgb(81, 90, 240, rgb);  // red
  EXPECT_NEAR(rgb[0], 255, 1);
  EXPECT_NEAR(rgb[1], 0, 1);
  EXPECT_NEAR(rgb[2], 0, 1);
}

TEST(PixelFormatTest, Yuv422PacksTwoPixelsWithAveragedChroma) {
  // Red then blue: Y0 = 81, Y1 = 41, Cb = (90.203 + 240) / 2 = 165.10, Cr = (240 + 109.786) / 2 = 174.89.
  const uint8_t rgb[6] = {255, 0, 0, 0, 0, 255};
  uint8_t yuyv[4];
  uint8_t uyvy[4];

  encode_row(PixelFormat::kYuyv, 0, rgb, 2, yuyv);
  encode_row(PixelFormat::kUyvy, 0, rgb, 2, uyvy);

  EXPECT_EQ(std::vector<int>(yuyv, yuyv + 4), (std::vector<int>{81, 165, 41, 175}));
  EXPECT_EQ(std::vector<int>(uyvy, uyvy + 4), (std::vector<int>{165, 81, 175, 41}));
}

TEST(PixelFormatTest, BayerKeepsTheChannelOfEachPatternSite) {
  // 2x2 image: (0,0) = 10 20 30, (1,0) = 40 50 60, (0,1) = 70 80 90, (1,1) = 100 110 120.
  const uint8_t rgb[12] = {10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120};
  struct Case {
    PixelFormat format;
    std::vector<int> expected;
  };
  const Case cases[] = {
      {PixelFormat::kBayerRggb, {10, 50, 80, 120}},
      {PixelFormat::kBayerBggr, {30, 50, 80, 100}},
      {PixelFormat::kBayerGrbg, {20, 40, 90, 110}},
      {PixelFormat::kBayerGbrg, {20, 60, 70, 110}},
  };
  for (const Case& c : cases) {
    uint8_t out[4];
    encode_image(c.format, rgb, 2, 2, out);
    EXPECT_EQ(std::vector<int>(out, out + 4), c.expected) << to_string(c.format);
  }
}

TEST(PixelFormatTest, SizesFollowTheFormat) {
  EXPECT_EQ(frame_bytes(PixelFormat::kRgb24, 640, 480), 921600u);
  EXPECT_EQ(frame_bytes(PixelFormat::kYuyv, 640, 480), 614400u);
  EXPECT_EQ(frame_bytes(PixelFormat::kUyvy, 1280, 720), 1843200u);
  EXPECT_EQ(frame_bytes(PixelFormat::kBayerGbrg, 640, 480), 307200u);
}

TEST(PixelFormatTest, NamesRoundTripAndUnknownNamesAreRejected) {
  for (PixelFormat f : kAllPixelFormats) EXPECT_EQ(parse_pixel_format(to_string(f)), f);
  EXPECT_THROW(parse_pixel_format("nv12"), std::invalid_argument);
}

TEST(PixelFormatTest, DecodingForViewingRestoresAFlatColourInEveryFormat) {
  constexpr int kW = 8;
  constexpr int kH = 6;
  std::vector<uint8_t> rgb(3 * kW * kH);
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = 200;
    rgb[i + 1] = 120;
    rgb[i + 2] = 40;
  }
  for (PixelFormat f : kAllPixelFormats) {
    std::vector<uint8_t> encoded(frame_bytes(f, kW, kH));
    std::vector<uint8_t> sut(3 * kW * kH);

    encode_image(f, rgb.data(), kW, kH, encoded.data());
    decode_to_rgb(f, encoded.data(), kW, kH, sut.data());

    for (size_t i = 0; i < sut.size(); ++i) {
      EXPECT_LE(std::abs(int(sut[i]) - int(rgb[i])), 2) << to_string(f) << " byte " << i;
    }
  }
}

TEST(PixelFormatTest, DemosaicingInterpolatesTheMissingChannelsBilinearly) {
  // RGGB 4x4 whose red sites hold 100, green 50 and blue 200: the inner pixel (1,1) is blue,
  // its red comes from its four diagonal neighbours and its green from its four edge neighbours.
  uint8_t bayer[16];
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) {
      const int c = bayer_channel(PixelFormat::kBayerRggb, x, y);
      bayer[4 * y + x] = c == 0 ? 100 : (c == 1 ? 50 : 200);
    }
  }
  uint8_t sut[48];

  decode_to_rgb(PixelFormat::kBayerRggb, bayer, 4, 4, sut);

  EXPECT_EQ(sut[3 * 5 + 0], 100);
  EXPECT_EQ(sut[3 * 5 + 1], 50);
  EXPECT_EQ(sut[3 * 5 + 2], 200);
}

}  // namespace
}  // namespace doppel::camera
