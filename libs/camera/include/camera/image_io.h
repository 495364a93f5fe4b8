#pragma once
// Writing frames for people to look at: PNG through libpng and the ground truth as JSON. Tool and
// test code, never the frame path.

#include <cstdint>
#include <string>

#include "camera/annotations.h"
#include "camera/frame.h"

namespace doppel::camera {

// Writes an 8-bit RGB image (3 * width * height bytes) as PNG. Throws std::runtime_error naming the
// path when the file cannot be written.
void write_png_rgb(const std::string& path, const uint8_t* rgb, int width_px, int height_px);

// The same image as PNG bytes in memory (e.g. for an HTTP answer). Throws std::runtime_error when
// libpng fails.
std::string encode_png_rgb(const uint8_t* rgb, int width_px, int height_px);

// Reads a PNG written by write_png_rgb (8-bit RGB) back; throws std::runtime_error otherwise.
void read_png_rgb(const std::string& path, std::string* rgb, int* width_px, int* height_px);

// The ground truth of one frame as a JSON object (nlohmann-json): the header's camera name, times,
// format, pose and lens, and `annotations` (every field of Annotation; NaN as null) as an array,
// empty when `annotations` is null. Any camera name gives valid JSON.
std::string frame_ground_truth_json(const FrameHeader& header, const FrameAnnotations* annotations);

}  // namespace doppel::camera
