#pragma once
// Writing frames for people to look at: PNG through libpng and the ground truth as JSON. Tool and
// test code, never the frame path.

#include <cstdint>
#include <string>

#include "camera/annotations.h"

namespace doppel::camera {

// Writes an 8-bit RGB image (3 * width * height bytes) as PNG. Throws std::runtime_error naming the
// path when the file cannot be written.
void write_png_rgb(const std::string& path, const uint8_t* rgb, int width_px, int height_px);

// Reads a PNG written by write_png_rgb (8-bit RGB) back; throws std::runtime_error otherwise.
void read_png_rgb(const std::string& path, std::string* rgb, int* width_px, int* height_px);

// The annotations as a JSON array of objects with every field of Annotation.
std::string annotations_to_json(const FrameAnnotations& annotations);

}  // namespace doppel::camera
