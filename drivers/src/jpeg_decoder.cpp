#include "jpeg_decoder.hpp"

#include <algorithm>
#include <cstring>

namespace calibd {

// Every libjpeg call below that can fail runs with setjmp armed: its error (or warning) handler
// longjmps back to the setjmp of the function that made the call. Nothing between the setjmp and
// a libjpeg call owns a resource or has a destructor, so the jump skips nothing.

void JpegDecoder::OnError(j_common_ptr info) {
  auto* errors = reinterpret_cast<Errors*>(info->err);
  errors->manager.format_message(info, errors->message);
  std::longjmp(errors->back, 1);
}

void JpegDecoder::OnMessage(j_common_ptr info, int level) {
  // level < 0: a warning, i.e. damaged data libjpeg would go on decoding (a truncated file ends
  // in grey, a corrupt segment in garbage): an error here. level >= 0: trace messages, ignored.
  if (level < 0) OnError(info);
}

void JpegDecoder::OnOutput(j_common_ptr /*info*/) {}  // never to stderr

JpegDecoder::JpegDecoder() {
  info_.err = jpeg_std_error(&errors_.manager);
  errors_.manager.error_exit = &JpegDecoder::OnError;
  errors_.manager.emit_message = &JpegDecoder::OnMessage;
  errors_.manager.output_message = &JpegDecoder::OnOutput;
  std::strcpy(errors_.message, "no JPEG decoder (libjpeg could not allocate its state)");
  if (setjmp(errors_.back)) return;
  jpeg_create_decompress(&info_);
  created_ = true;
  errors_.message[0] = '\0';
}

JpegDecoder::~JpegDecoder() { jpeg_destroy_decompress(&info_); }  // a no-op if not created

bool JpegDecoder::ReadHeader(const uint8_t* data, size_t size, int* width, int* height) {
  if (!created_) return false;
  if (setjmp(errors_.back)) {
    jpeg_abort_decompress(&info_);
    return false;
  }
  // The source manager is allocated once (libjpeg's permanent pool) and pointed at new data here.
  jpeg_mem_src(&info_, data, static_cast<unsigned long>(size));
  jpeg_read_header(&info_, TRUE);
  *width = static_cast<int>(info_.image_width);
  *height = static_cast<int>(info_.image_height);
  return true;
}

bool JpegDecoder::Decode(uint8_t* rows, size_t stride) {
  if (!created_) return false;
  if (setjmp(errors_.back)) {
    jpeg_abort_decompress(&info_);
    return false;
  }
  info_.out_color_space = JCS_GRAYSCALE;  // Y of YCbCr as is; RGB images weighted by libjpeg
  jpeg_start_decompress(&info_);
  if (info_.output_components != 1 || info_.output_width != info_.image_width ||
      info_.output_height != info_.image_height) {
    std::strcpy(errors_.message, "unexpected output format");
    jpeg_abort_decompress(&info_);
    return false;
  }
  // libjpeg returns at most rec_outbuf_height rows (1 to 4) per call: a few row pointers on the
  // stack at a time.
  constexpr JDIMENSION kBatch = 8;
  JSAMPROW batch[kBatch];
  while (info_.output_scanline < info_.output_height) {
    const JDIMENSION first = info_.output_scanline;
    const JDIMENSION n = std::min(kBatch, info_.output_height - first);
    for (JDIMENSION i = 0; i < n; ++i) batch[i] = rows + static_cast<size_t>(first + i) * stride;
    jpeg_read_scanlines(&info_, batch, n);
  }
  jpeg_finish_decompress(&info_);
  return true;
}

void JpegDecoder::Abort() { jpeg_abort_decompress(&info_); }

}  // namespace calibd
