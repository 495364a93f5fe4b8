#include "camera/image_io.h"

#include <png.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace doppel::camera {
namespace {

struct FileCloser {
  void operator()(FILE* f) const noexcept { std::fclose(f); }
};

}  // namespace

void write_png_rgb(const std::string& path, const uint8_t* rgb, int width_px, int height_px) {
  std::unique_ptr<FILE, FileCloser> file(std::fopen(path.c_str(), "wb"));
  if (!file) throw std::runtime_error(path + ": cannot open for writing");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (png == nullptr || info == nullptr) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error(path + ": libpng could not start");
  }
  std::vector<png_bytep> rows(static_cast<size_t>(height_px));
  for (int y = 0; y < height_px; ++y) {
    rows[y] = const_cast<png_bytep>(rgb + 3 * static_cast<size_t>(y) * width_px);
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error(path + ": libpng failed while writing");
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, static_cast<png_uint_32>(width_px), static_cast<png_uint_32>(height_px), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, 3);
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

void read_png_rgb(const std::string& path, std::string* rgb, int* width_px, int* height_px) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path.c_str())) {
    throw std::runtime_error(path + ": not a readable PNG: " + image.message);
  }
  image.format = PNG_FORMAT_RGB;
  rgb->assign(PNG_IMAGE_SIZE(image), '\0');
  if (!png_image_finish_read(&image, nullptr, rgb->data(), 0, nullptr)) {
    png_image_free(&image);
    throw std::runtime_error(path + ": PNG decoding failed: " + image.message);
  }
  *width_px = static_cast<int>(image.width);
  *height_px = static_cast<int>(image.height);
}

std::string annotations_to_json(const FrameAnnotations& a) {
  std::ostringstream out;
  out.precision(6);
  auto num = [&out](float v) {
    if (std::isfinite(v)) {
      out << v;
    } else {
      out << "null";
    }
  };
  out << "[";
  for (uint32_t i = 0; i < a.count && i < kMaxAnnotations; ++i) {
    const Annotation& x = a.items[i];
    out << (i ? ",\n " : "\n ") << "{\"kind\": \"" << to_string(x.kind) << "\", \"object_id\": " << x.object_id
        << ", \"in_fov\": " << (x.in_fov ? "true" : "false") << ", \"visible\": " << (x.visible ? "true" : "false")
        << ", \"visible_px\": " << x.visible_px << ", \"u_px\": ";
    num(x.u_px);
    out << ", \"v_px\": ";
    num(x.v_px);
    out << ", \"bbox\": [";
    num(x.bbox_min_u);
    out << ", ";
    num(x.bbox_min_v);
    out << ", ";
    num(x.bbox_max_u);
    out << ", ";
    num(x.bbox_max_v);
    out << "], \"distance_m\": ";
    num(x.distance_m);
    out << ", \"position_w_m\": [";
    num(x.x_w_m);
    out << ", ";
    num(x.y_w_m);
    out << ", ";
    num(x.z_w_m);
    out << "], \"heading_rad\": ";
    num(x.heading_rad);
    out << "}";
  }
  out << "\n]\n";
  return out.str();
}

}  // namespace doppel::camera
