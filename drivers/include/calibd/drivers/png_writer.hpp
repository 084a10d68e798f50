#pragma once
/// \file
/// PNG encoding with libpng alone (its simplified write API), so that a program writing pictures
/// (calibd-agent's --debug) links no OpenCV imgcodecs.

#include <cstdint>
#include <string>

namespace calibd {

/// Encodes a `width` x `height` 8-bit RGB image (rows packed, 3 bytes a pixel) into `png`. False
/// with `error` saying why (empty image, libpng's message).
bool EncodePngRgb(const uint8_t* rgb, int width, int height, std::string* png, std::string* error);

}  // namespace calibd
