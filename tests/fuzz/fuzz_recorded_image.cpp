// Images of a recorded folder (PNG 8/16 bit, JPEG) as calibd-calibrate --folder and calibd-import
// load them: LoadRecordedImage reads a path, so each input is written to one file in the
// process's temp directory first. Both of its JPEG paths are taken (kept as bytes, or decoded to
// mono8 by OpenCV).

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/recorded_folder.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  // The extension decides nothing in OpenCV's imread (it sniffs the signature); .png and .jpg
  // alternate on the first byte so that any extension-based path is exercised too.
  const bool jpg = size > 0 && (data[0] & 1) != 0;
  static const std::string png_path = (calibd::fuzz::ProcessTempDir() / "image.png").string();
  static const std::string jpg_path = (calibd::fuzz::ProcessTempDir() / "image.jpg").string();
  calibd::RecordedEntry entry;
  entry.path = jpg ? jpg_path : png_path;
  calibd::fuzz::WriteBytes(entry.path, data, size);
  for (const bool keep_jpeg : {false, true}) {
    calibd::camera_frame_t msg;
    std::string error;
    if (!calibd::LoadRecordedImage(entry, "cam0", keep_jpeg, &msg, &error)) {
      Check(!error.empty(), "a refused image says why");
      continue;
    }
    Check(msg.size == static_cast<int32_t>(msg.data.size()), "size matches the data");
    if (msg.encoding == calibd::camera_frame_t::ENCODING_MONO8)
      Check(msg.stride == msg.width &&
                msg.data.size() == static_cast<size_t>(msg.width) * static_cast<size_t>(msg.height),
            "mono8 rows fill the data");
  }
  return 0;
}
