#pragma once
/// \file
/// JPEG to 8-bit grey with libjpeg-turbo, without OpenCV's imgcodecs (which brings ~140 shared
/// libraries into the agent) and without allocating per frame: one decompressor is created once
/// and reused for every image, and the pixels go straight into the caller's rows.
///
/// libjpeg reports errors through a callback that must not return; ours longjmps back into the
/// call that failed, which then fails with libjpeg's message. Warnings (corrupt or truncated
/// data, which libjpeg would otherwise paper over with grey) are errors here too: a damaged
/// frame is refused, not detected on. libjpeg's own working memory (its image pool, malloc'd in
/// jpeg_start_decompress and freed when the image is finished or aborted) is the library's.

#include <csetjmp>
#include <cstddef>
#include <cstdint>
#include <cstdio>  // before jpeglib.h, which uses size_t and FILE without including their headers

#include <jpeglib.h>

namespace calibd {

class JpegDecoder {
 public:
  JpegDecoder();
  ~JpegDecoder();
  JpegDecoder(const JpegDecoder&) = delete;
  JpegDecoder& operator=(const JpegDecoder&) = delete;

  /// Reads the header of the `size` bytes at `data` (which must stay valid until Decode or
  /// Abort) and reports the image's size. False with message() when the data is no JPEG or its
  /// header is damaged.
  bool ReadHeader(const uint8_t* data, size_t size, int* width, int* height);
  /// Decodes the image whose header was read, as grey (colour images are converted by libjpeg),
  /// into `height` rows of `width` bytes starting at `rows`, `stride` bytes apart. False with
  /// message() on damaged data (the rows may then be partly written). Either way the decoder is
  /// ready for the next ReadHeader.
  bool Decode(uint8_t* rows, size_t stride);
  /// Drops an image whose header was read but which is not decoded.
  void Abort();

  /// libjpeg's message for the last failure.
  const char* message() const { return errors_.message; }

 private:
  struct Errors {
    jpeg_error_mgr manager;  // first: libjpeg hands the callbacks a pointer to it
    std::jmp_buf back;
    char message[JMSG_LENGTH_MAX];
  };
  static void OnError(j_common_ptr info);
  static void OnMessage(j_common_ptr info, int level);
  static void OnOutput(j_common_ptr info);

  Errors errors_{};
  jpeg_decompress_struct info_{};
  bool created_ = false;
};

}  // namespace calibd
