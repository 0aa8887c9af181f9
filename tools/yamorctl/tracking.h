// yamorctl's LED tracking commands (issue 15, thesis C.2.5): `track` reads
// the camera application (docs/camapp.md) directly — it must work before a
// calibration exists, to measure the reference points, and needs no daemon —
// and `calibrate` fits the homography to reference points and writes the
// calibration file.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>

namespace yamor::yamorctl {

/// What `yamorctl track` reads and where it writes.
struct TrackOptions {
  std::string camapp = "127.0.0.1:2225";  ///< CamApp (or yamor-camapp) HOST:PORT.
  std::string calibration;  ///< Calibration file; "" = raw pixels only.
  int width = 640;          ///< Image width without a calibration [px].
  int height = 480;         ///< Image height without a calibration [px].
  std::string record;       ///< CSV file; "" = print each sample.
  double seconds = 0.0;     ///< Stop after this long [s]; 0 = no limit.
  std::uint64_t samples = 0;  ///< Stop after this many samples; 0 = no limit.
  double connect_timeout = 10.0;  ///< Give up when not connected within [s].
  bool json = false;        ///< Print samples as JSON lines.
};

/// The track CSV's header: host time since the start [s], the sample as sent,
/// the corrected position [m] (empty when not seen, uncorrectable or without
/// a calibration), and the connection it came on (1, 2, ... after restarts).
inline constexpr char kTrackCsvHeader[] =
    "host_time,seq,camera_time_us,seen,pixel_x,pixel_y,x,y,connection";

/// Runs `yamorctl track`; returns the exit status (0; 2 for a bad option or
/// an unreadable/unwritable file; the code number of an error otherwise,
/// e.g. 14 UNAVAILABLE when never connected). Thread-safety: reentrant.
int Track(const TrackOptions& options, std::ostream& out, std::ostream& err);

/// What `yamorctl calibrate` reads and writes.
struct CalibrateOptions {
  std::string points;   ///< A calibration file, or (with `lens`) a file of `x y X Y` lines.
  std::string lens;     ///< Calibration file whose lens is used ("" = the points file's).
  std::string output;   ///< Write the calibration file here ("" = only report).
  std::optional<double> led_height;  ///< LED height written [m] (default: the file's).
  bool json = false;    ///< Report as one JSON object.
};

/// Runs `yamorctl calibrate`: the reprojection error of every point, RMS and
/// maximum; returns the exit status as Track. Thread-safety: reentrant.
int Calibrate(const CalibrateOptions& options, std::ostream& out, std::ostream& err);

}  // namespace yamor::yamorctl
