#pragma once
/// \file
/// Data identifiers of ReadDataByIdentifier 0x22 / WriteDataByIdentifier 0x2E and their
/// encodings: every scaling of the supplier DIDs is defined here. Multi-byte values big-endian.
///
/// Identification DIDs (ISO 14229-1 Annex C.1), ASCII padded with spaces to a fixed size:
/// - 0xF18C ECU serial number, 16 bytes (UdsConfig::ecu_serial)
/// - 0xF190 VIN, 17 bytes; also writable (0x2E) in the extended session once unlocked
/// - 0xF195 software version, 16 bytes
/// - 0xF19B calibration date, 4 bytes BCD YYYY MM DD (UTC) of the current calibration's
///   creation; 00 00 00 00 when there is none
/// Supplier DIDs (0xFD00-0xFEFF: system-supplier-specific in Annex C.1):
/// - 0xFD00 current T_camera_lidar, 24 bytes: ExtrinsicFigures, 6 x int32
/// - 0xFD01 factory / end-of-line reference T_camera_lidar, 24 bytes: ExtrinsicFigures
/// - 0xFD02 quality figures of the current calibration, 16 bytes: QualityFigures, 8 x uint16
/// - 0xFD03 LiDAR serial number, 32 bytes ASCII
/// - 0xFD04 camera serial number, 32 bytes ASCII
/// - 0xFD05 calibration state, 2 bytes: CalibrationState, then the calibrate routine's
///   RoutineStatus (routines.hpp)
/// - 0xFD06 capture coverage of the running (or last) session, 16 bytes (capture_guidance.hpp):
///   byte 0 mode (0 moving, 1 static), byte 1 distance bins seen (bit b: bin b), byte 2 bins
///   needed, bytes 3-4 image cells seen (bit c: cell c of the 4 x 4 grid, row-major from the
///   top-left), byte 5 cells needed, then u16 each: frame pairs with boards, frame pairs needed,
///   target frame pairs, boards, boards needed
///
/// ExtrinsicFigures (T_camera_lidar: p_camera = R * p_lidar + t): x, y, z of t in 0.01 mm, then
/// roll, pitch, yaw in micro-degrees (R = Rz(yaw) * Ry(pitch) * Rx(roll)), each int32 rounded to
/// nearest and saturated; all six 0x7FFFFFFF when there is no such calibration.
/// QualityFigures: reprojection mean in 0.01 px, LiDAR residual RMS in 0.1 mm, rotation sigma in
/// 0.001 deg, translation sigma in 0.1 mm, frames used, boards used, then the predicted 99 % bound
/// on the calibration's own error: rotation in 0.001 deg, translation in 0.1 mm (0xFFFF: none
/// known, e.g. a factory value); each saturated at 0xFFFF.

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "calibd/agent/capture_guidance.hpp"

namespace calibd::uds {

enum DataIdentifier : uint16_t {
  kDidEcuSerial = 0xF18C,
  kDidVin = 0xF190,
  kDidSoftwareVersion = 0xF195,
  kDidCalibrationDate = 0xF19B,
  kDidCurrentExtrinsic = 0xFD00,
  kDidReferenceExtrinsic = 0xFD01,
  kDidQualityFigures = 0xFD02,
  kDidLidarSerial = 0xFD03,
  kDidCameraSerial = 0xFD04,
  kDidCalibrationState = 0xFD05,
  kDidCaptureCoverage = 0xFD06,
};

inline constexpr size_t kVinSize = 17;
inline constexpr size_t kEcuSerialSize = 16;
inline constexpr size_t kSoftwareVersionSize = 16;
inline constexpr size_t kSensorSerialSize = 32;
inline constexpr size_t kExtrinsicSize = 24;
inline constexpr size_t kQualitySize = 16;
inline constexpr size_t kCoverageSize = 16;
inline constexpr int32_t kExtrinsicNotAvailable = 0x7FFFFFFF;

/// Scalings (one LSB).
inline constexpr double kTranslationLsbM = 1e-5;       ///< 0.01 mm
inline constexpr double kAngleLsbDeg = 1e-6;           ///< 1 micro-degree
inline constexpr double kReprojectionLsbPx = 0.01;     ///< 0.01 px
inline constexpr double kLengthFigureLsbM = 1e-4;      ///< 0.1 mm (residual, sigma, delta)
inline constexpr double kRotationFigureLsbDeg = 1e-3;  ///< 0.001 deg (sigma, delta)

/// An extrinsic as the owner hands it over (already in translation + roll/pitch/yaw).
struct ExtrinsicFigures {
  bool available = false;
  double x_m = 0, y_m = 0, z_m = 0;
  double roll_deg = 0, pitch_deg = 0, yaw_deg = 0;
};

struct QualityFigures {
  double reprojection_mean_px = 0, residual_rms_m = 0;
  double rotation_sigma_deg = 0, translation_sigma_m = 0;
  int frames_used = 0, boards_used = 0;
  double rotation_bound_deg = 0, translation_bound_m = 0;  ///< 0: none known
};
/// The bounds' "none known" in DID 0xFD02.
inline constexpr uint16_t kBoundNotAvailable = 0xFFFF;

/// health_t.calibration_state as one byte (DID 0xFD05 byte 0).
enum class CalibrationState : uint8_t { kValid = 0, kNotPerformed = 1, kRecalibrationRequired = 2 };

/// value / lsb rounded to nearest, saturated to the type's range (NaN -> 0).
int32_t ScaleToInt32(double value, double lsb);
uint16_t ScaleToUint16(double value, double lsb);

/// Writers into `out` (at least the DID's size); each returns the bytes written.
size_t PutU16(uint8_t* out, uint16_t v);
size_t PutI32(uint8_t* out, int32_t v);
/// `text` truncated or padded with spaces to exactly `size` bytes.
size_t PutPaddedAscii(uint8_t* out, std::string_view text, size_t size);
size_t EncodeExtrinsic(const ExtrinsicFigures& e, uint8_t* out);
size_t EncodeQuality(const QualityFigures& q, uint8_t* out);
size_t EncodeCoverage(const CaptureCoverage& c, uint8_t* out);
/// Reads kCoverageSize bytes of DID 0xFD06 back (calibd-tester).
CaptureCoverage DecodeCoverage(const uint8_t* in);
/// BCD date of a UTC time (YYYY MM DD); 4 zero bytes for unix_s <= 0.
size_t EncodeBcdDate(int64_t unix_s, uint8_t* out);

}  // namespace calibd::uds
