#include "camera/image_io.h"

#include <png.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>
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

std::string encode_png_rgb(const uint8_t* rgb, int width_px, int height_px) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width_px);
  image.height = static_cast<png_uint_32>(height_px);
  image.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_get_memory_size(image, size, 0, rgb, 0, nullptr)) {
    throw std::runtime_error(std::string("PNG encoding failed: ") + image.message);
  }
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, rgb, 0, nullptr)) {
    throw std::runtime_error(std::string("PNG encoding failed: ") + image.message);
  }
  out.resize(size);
  return out;
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

namespace {

nlohmann::json annotation_json(const Annotation& x) {
  return {{"kind", to_string(x.kind)},
          {"object_id", x.object_id},
          {"in_fov", x.in_fov != 0},
          {"visible", x.visible != 0},
          {"visible_px", x.visible_px},
          {"u_px", x.u_px},
          {"v_px", x.v_px},
          {"bbox", {x.bbox_min_u, x.bbox_min_v, x.bbox_max_u, x.bbox_max_v}},
          {"distance_m", x.distance_m},
          {"position_w_m", {x.x_w_m, x.y_w_m, x.z_w_m}},
          {"heading_rad", x.heading_rad}};
}

}  // namespace

std::string frame_ground_truth_json(const FrameHeader& h, const FrameAnnotations* annotations) {
  const LensConfig& lens = h.lens;
  nlohmann::json truth = {
      {"camera", std::string(h.camera_name, strnlen(h.camera_name, sizeof(h.camera_name)))},
      {"sequence", h.sequence},
      {"sim_time_ns", h.sim_time_ns},
      {"exposure_time_ns", h.exposure_time_ns},
      {"wall_time_ns", h.wall_time_ns},
      {"format", to_string(static_cast<PixelFormat>(h.format))},
      {"width_px", h.width_px},
      {"height_px", h.height_px},
      {"camera_position_w_m", h.position_w_m},
      {"camera_orientation_w_wxyz", h.orientation_w},
      {"lens",
       {{"model", to_string(lens.model)},
        {"fx_px", lens.fx_px},
        {"fy_px", lens.fy_px},
        {"cx_px", lens.cx_px},
        {"cy_px", lens.cy_px},
        {"k1", lens.k1},
        {"k2", lens.k2},
        {"k3", lens.k3},
        {"p1", lens.p1},
        {"p2", lens.p2},
        {"fov_deg", lens.fov_deg}}},
      {"frames_dropped", h.frames_dropped},
      {"annotations", nlohmann::json::array()}};
  if (annotations != nullptr) {
    for (uint32_t i = 0; i < annotations->count && i < kMaxAnnotations; ++i) {
      truth["annotations"].push_back(annotation_json(annotations->items[i]));
    }
  }
  // A name that is not UTF-8 is written with U+FFFD rather than refused: the pixels still get saved.
  return truth.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace doppel::camera
