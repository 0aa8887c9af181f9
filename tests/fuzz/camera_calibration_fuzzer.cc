// libFuzzer target for the LED tracker's camera calibration file
// (host/camera_model.h, docs/camapp.md "Calibration file"): a file a lab hands
// yamord --tracker-calibration. Input: the file text. Checks, aborting on
// violation:
//  - ParseCameraCalibration and CameraModel never crash and reject only with
//    a yamor::Error of a caller code (INVALID_ARGUMENT / OUT_OF_RANGE) whose
//    message names the file ("fuzz");
//  - an accepted model maps the image centre to a finite ground position, or
//    refuses it with OUT_OF_RANGE; never a NaN passed off as a position;
//  - an accepted calibration written by FormatCameraCalibration (yamorctl
//    calibrate --output) reads back to the same numbers;
//  - ParseReferencePoints (yamorctl calibrate's points file) rejects only
//    with INVALID_ARGUMENT naming the file, and accepts only finite points.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "common/status.h"
#include "host/camera_model.h"

#define FUZZ_ASSERT(condition)                                                      \
  do {                                                                              \
    if (!(condition)) {                                                             \
      std::fprintf(stderr, "camera_calibration_fuzzer: %s failed at line %d\n",     \
                   #condition, __LINE__);                                           \
      std::abort();                                                                 \
    }                                                                               \
  } while (false)

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const yamor::host::CameraCalibration calibration =
        yamor::host::ParseCameraCalibration(text, "fuzz");
    const yamor::host::CameraModel model(calibration, "fuzz");
    try {
      const Eigen::Vector2d ground =
          model.PixelToGround({calibration.lens.cx, calibration.lens.cy});
      FUZZ_ASSERT(std::isfinite(ground.x()) && std::isfinite(ground.y()));
    } catch (const yamor::Error& e) {
      FUZZ_ASSERT(e.code() == yamor::StatusCode::kOutOfRange);
    }
    const yamor::host::CameraCalibration back =
        yamor::host::ParseCameraCalibration(yamor::host::FormatCameraCalibration(calibration, "fuzz"), "back");
    FUZZ_ASSERT(back.points.size() == calibration.points.size());
    FUZZ_ASSERT(back.lens.k1 == calibration.lens.k1 && back.lens.fx == calibration.lens.fx);
    FUZZ_ASSERT(back.led_height == calibration.led_height);
    for (std::size_t i = 0; i < back.points.size(); ++i) {
      FUZZ_ASSERT(back.points[i].pixel == calibration.points[i].pixel);
      FUZZ_ASSERT(back.points[i].ground == calibration.points[i].ground);
    }
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument ||
                e.code() == yamor::StatusCode::kOutOfRange);
    FUZZ_ASSERT(std::string(e.what()).find("fuzz") != std::string::npos);
  }
  try {
    for (const auto& point : yamor::host::ParseReferencePoints(text, "fuzz")) {
      FUZZ_ASSERT(point.pixel.allFinite() && point.ground.allFinite() && point.line > 0);
    }
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument);
    FUZZ_ASSERT(std::string(e.what()).find("fuzz:") == 0);
  }
  return 0;
}
