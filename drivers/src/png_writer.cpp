#include "calibd/drivers/png_writer.hpp"

#include <png.h>

#include <cstring>

namespace calibd {

bool EncodePngRgb(const uint8_t* rgb, int width, int height, std::string* png, std::string* error) {
  if (rgb == nullptr || width <= 0 || height <= 0) {
    if (error) *error = "empty picture";
    return false;
  }
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  const png_int_32 stride = 3 * width;
  // The first call measures, the second writes.
  png_alloc_size_t size = 0;
  if (png_image_write_to_memory(&image, nullptr, &size, 0, rgb, stride, nullptr) && size > 0) {
    png->resize(size);
    if (png_image_write_to_memory(&image, &(*png)[0], &size, 0, rgb, stride, nullptr)) {
      png->resize(size);
      return true;
    }
  }
  if (error) *error = std::string("cannot encode the picture: ") + image.message;
  png_image_free(&image);
  return false;
}

}  // namespace calibd
