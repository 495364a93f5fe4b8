// The V4L2 device's formats, sizes, controls and copy (shim/v4l2_format.h) against the V4L2 spec
// (linux/videodev2.h, "Packed YUV formats": YUYV and UYVY take 2 bytes per pixel, Y0 Cb Y1 Cr and
// Cb Y0 Cr Y1; 8-bit Bayer one byte per pixel) and arithmetic.
#include <gtest/gtest.h>

#include <vector>

#include "shim/v4l2_format.h"

namespace doppel::shim {
namespace {

constexpr uint32_t kYuyvSource = static_cast<uint32_t>(SourceFormat::kYuyv);
constexpr uint32_t kUyvySource = static_cast<uint32_t>(SourceFormat::kUyvy);
constexpr uint32_t kBayerSource = static_cast<uint32_t>(SourceFormat::kBayerGrbg);

TEST(V4l2Format, DoppelFormatsHaveTheirFourccs) {
  EXPECT_EQ(fourcc_of(kYuyvSource), V4L2_PIX_FMT_YUYV);
  EXPECT_EQ(fourcc_of(kUyvySource), V4L2_PIX_FMT_UYVY);
  EXPECT_EQ(fourcc_of(kBayerSource), V4L2_PIX_FMT_SGRBG8);
  EXPECT_EQ(fourcc_of(static_cast<uint32_t>(SourceFormat::kRgb24)), V4L2_PIX_FMT_RGB24);
  EXPECT_EQ(fourcc_of(99), 0u);
}

TEST(V4l2Format, Yuyv640x480OffersItselfAndTheBinnedSizes) {
  const SourceCamera cam{kYuyvSource, 640, 480, 30};
  ASSERT_EQ(format_count(cam), 1);
  ASSERT_EQ(size_count(cam, V4L2_PIX_FMT_YUYV), 3);
  const Mode full = mode_at(cam, V4L2_PIX_FMT_YUYV, 0);
  EXPECT_EQ(full.bytesperline, 1280u);
  EXPECT_EQ(full.sizeimage, 614400u);
  const Mode half = mode_at(cam, V4L2_PIX_FMT_YUYV, 1);
  EXPECT_EQ(half.width, 320);
  EXPECT_EQ(half.height, 240);
  EXPECT_EQ(half.sizeimage, 153600u);
  EXPECT_EQ(mode_at(cam, V4L2_PIX_FMT_YUYV, 2).width, 160);
  EXPECT_EQ(size_count(cam, V4L2_PIX_FMT_SGRBG8), 0);
}

TEST(V4l2Format, NearestSizeAndFallbackFormatAsDriversPick) {
  const SourceCamera cam{kYuyvSource, 640, 480, 30};
  EXPECT_EQ(nearest_mode(cam, V4L2_PIX_FMT_YUYV, 320, 240).width, 320);
  EXPECT_EQ(nearest_mode(cam, V4L2_PIX_FMT_YUYV, 100, 100).width, 160);
  EXPECT_EQ(nearest_mode(cam, V4L2_PIX_FMT_YUYV, 4000, 3000).width, 640);
  const Mode other = nearest_mode(cam, V4L2_PIX_FMT_MJPEG, 640, 480);
  EXPECT_EQ(other.fourcc, V4L2_PIX_FMT_YUYV);
}

TEST(V4l2Format, BayerCamerasOfferTheirOrderAtTheirSizeOnly) {
  const SourceCamera cam{kBayerSource, 640, 480, 30};
  ASSERT_EQ(format_count(cam), 1);
  EXPECT_EQ(format_at(cam, 0), V4L2_PIX_FMT_SGRBG8);
  ASSERT_EQ(size_count(cam, V4L2_PIX_FMT_SGRBG8), 1);
  EXPECT_EQ(mode_at(cam, V4L2_PIX_FMT_SGRBG8, 0).sizeimage, 640u * 480u);
}

TEST(V4l2Format, FrameIntervalIsTheReciprocalRateReduced) {
  const v4l2_fract thirty = frame_interval(30.0);
  EXPECT_EQ(thirty.numerator, 1u);
  EXPECT_EQ(thirty.denominator, 30u);
  const v4l2_fract ntsc = frame_interval(29.97);
  EXPECT_EQ(ntsc.numerator, 100u);  // 1000 / 29970 reduced
  EXPECT_EQ(ntsc.denominator, 2997u);
}

TEST(V4l2Format, ControlsAreInIdOrderWithTheirClasses) {
  uint32_t last = 0;
  for (int i = 0; i < control_count(); ++i) {
    EXPECT_GT(control_at(i, 30).id, last);
    last = control_at(i, 30).id;
  }
  EXPECT_EQ(control_at(0, 30).type, static_cast<uint32_t>(V4L2_CTRL_TYPE_CTRL_CLASS));
  // Exposure in 100 us units: default half of the 33.3 ms frame period, at most the period.
  const ControlInfo exposure = control_at(control_index(V4L2_CID_EXPOSURE_ABSOLUTE), 30);
  EXPECT_EQ(exposure.default_value, 167);
  EXPECT_EQ(exposure.maximum, 333);
  EXPECT_EQ(control_index(V4L2_CID_HUE), -1);
  EXPECT_STREQ(exposure_menu_name(V4L2_EXPOSURE_MANUAL), "Manual Mode");
  EXPECT_EQ(exposure_menu_name(V4L2_EXPOSURE_AUTO), nullptr);
}

TEST(V4l2Format, DefaultControlsLeaveTheImageUntouched) {
  const ToneCurves curves = tone_curves(default_controls(30), 30, kYuyvSource);
  EXPECT_TRUE(curves.identity);
  for (int i = 0; i < 256; ++i) EXPECT_EQ(curves.luma[i], i);
}

TEST(V4l2Format, ControlsMoveLumaAndChromaTheWayTheyAreNamed) {
  ControlValues v = default_controls(30);
  v.saturation = 0;
  const ToneCurves grey = tone_curves(v, 30, kYuyvSource);
  EXPECT_FALSE(grey.identity);
  EXPECT_EQ(grey.chroma[16], 128);
  EXPECT_EQ(grey.chroma[240], 128);
  v = default_controls(30);
  v.exposure_auto = V4L2_EXPOSURE_MANUAL;
  v.exposure_absolute = 334;  // twice the default exposure: twice the signal above black (16)
  const ToneCurves bright = tone_curves(v, 30, kYuyvSource);
  EXPECT_EQ(bright.luma[16], 16);
  EXPECT_EQ(bright.luma[66], 16 + 100);
  EXPECT_EQ(bright.luma[200], 235);  // clipped at the top of studio range
  v = default_controls(30);
  v.exposure_absolute = 334;  // ignored under automatic exposure
  EXPECT_TRUE(tone_curves(v, 30, kYuyvSource).identity);
  v = default_controls(30);
  v.gain = 32;  // 2x
  EXPECT_EQ(tone_curves(v, 30, kYuyvSource).luma[66], 116);
  v = default_controls(30);
  v.brightness = 255;
  EXPECT_GT(tone_curves(v, 30, kYuyvSource).luma[100], 100);
}

TEST(V4l2Format, WhiteBalanceAtD65IsNeutralAndWarmSettingsTurnBlue) {
  double gains[3];
  white_balance_gains(6500, gains);
  EXPECT_NEAR(gains[0], 1.0, 1e-9);
  EXPECT_NEAR(gains[1], 1.0, 1e-9);
  EXPECT_NEAR(gains[2], 1.0, 1e-9);
  white_balance_gains(2800, gains);  // the camera expects warm light: it lifts blue, cuts red
  EXPECT_LT(gains[0], 1.0);
  EXPECT_EQ(gains[1], 1.0);
  EXPECT_GT(gains[2], 1.5);
}

TEST(V4l2Format, CopyIsExactAtTheCamerasOwnModeAndBinsTwoByTwo) {
  const SourceCamera cam{kYuyvSource, 4, 2, 30};
  // Two rows of two YUYV pairs: Y0 U Y1 V.
  const std::vector<uint8_t> src = {10, 100, 20, 200, 30, 110, 40, 210,   //
                                    50, 120, 60, 220, 70, 130, 80, 230};
  const ToneCurves curves = tone_curves(default_controls(30), 30, kYuyvSource);
  std::vector<uint8_t> out(16, 0);
  EXPECT_EQ(convert_frame(cam, src.data(), 8, mode_at(cam, V4L2_PIX_FMT_YUYV, 0), curves, out.data()), 16u);
  EXPECT_EQ(out, src);
  const Mode half = mode_at(cam, V4L2_PIX_FMT_YUYV, 1);
  ASSERT_EQ(half.width, 2);
  ASSERT_EQ(half.height, 1);
  std::vector<uint8_t> binned(4, 0);
  convert_frame(cam, src.data(), 8, half, curves, binned.data());
  // Y0: (10 + 20 + 50 + 60) / 4 = 35; Y1: (30 + 40 + 70 + 80) / 4 = 55; U: (100+110+120+130)/4 = 115; V 215.
  EXPECT_EQ(binned, (std::vector<uint8_t>{35, 115, 55, 215}));
}

TEST(V4l2Format, UyvyCamerasAlsoGiveYuyvWithTheBytesReordered) {
  const SourceCamera cam{kUyvySource, 2, 1, 30};
  ASSERT_EQ(format_count(cam), 2);
  EXPECT_EQ(format_at(cam, 1), V4L2_PIX_FMT_YUYV);
  const std::vector<uint8_t> src = {100, 10, 200, 20};  // U Y0 V Y1
  std::vector<uint8_t> out(4, 0);
  convert_frame(cam, src.data(), 4, mode_at(cam, V4L2_PIX_FMT_YUYV, 0), tone_curves(default_controls(30), 30, kUyvySource),
                out.data());
  EXPECT_EQ(out, (std::vector<uint8_t>{10, 100, 20, 200}));
}

}  // namespace
}  // namespace doppel::shim
