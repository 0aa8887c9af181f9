// libFuzzer target for the LED tracker's camera calibration file
// (host/camera_model.h, docs/camapp.md "Calibration file"): a file a lab hands
// yamord --tracker-calibration. Input: the file text. Checks, aborting on
// violation:
//  - ParseCameraCalibration and CameraModel never crash and reject only with
//    a yamor::Error of a caller code (INVALID_ARGUMENT / OUT_OF_RANGE) whose
//    message names the file ("fuzz");
//  - an accepted model maps the image centre to a finite ground position, or
//    refuses it with OUT_OF_RANGE; never a NaN passed off as a position.
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
  } catch (const yamor::Error& e) {
    FUZZ_ASSERT(e.code() == yamor::StatusCode::kInvalidArgument ||
                e.code() == yamor::StatusCode::kOutOfRange);
    FUZZ_ASSERT(std::string(e.what()).find("fuzz") != std::string::npos);
  }
  return 0;
}
