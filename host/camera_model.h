// The ceiling camera's model for LED tracking (issue 15, docs/camapp.md):
// Brown–Conrady lens distortion with an iterative inverse, and a homography
// from undistorted pixels to metres on the ground plane at the LED's height,
// estimated by the normalised DLT. No network, no driver: library yamor_tracking.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace yamor::host {

/// Pinhole intrinsics and Brown–Conrady coefficients of a camera, in pixels.
struct LensParameters {
  int width = 640;         ///< Image width [px].
  int height = 480;        ///< Image height [px].
  double fx = 0;           ///< Focal length along x [px].
  double fy = 0;           ///< Focal length along y [px].
  double cx = 0;           ///< Principal point, column [px].
  double cy = 0;           ///< Principal point, row [px].
  double k1 = 0;           ///< Radial coefficient of r².
  double k2 = 0;           ///< Radial coefficient of r⁴.
  double k3 = 0;           ///< Radial coefficient of r⁶.
  double p1 = 0;           ///< Tangential coefficient p1.
  double p2 = 0;           ///< Tangential coefficient p2.
};

/// A validated lens: ideal pinhole pixels <-> raw (distorted) pixels.
/// Thread-safety: immutable after construction; safe to share between threads.
class LensModel {
 public:
  /// Validates `params` (finite, focal > 0, principal point inside the image,
  /// every border pixel invertible); INVALID_ARGUMENT naming the bad value.
  explicit LensModel(const LensParameters& params);

  /// The parameters this lens was built from.
  const LensParameters& params() const noexcept { return params_; }

  /// Raw pixel seen for the ideal (undistorted) pinhole pixel `ideal`.
  Eigen::Vector2d Distort(const Eigen::Vector2d& ideal) const;

  /// Ideal pixel whose distortion is `raw`, by Newton's method to 1e-9 px;
  /// OUT_OF_RANGE naming the pixel when the iteration does not converge.
  Eigen::Vector2d Undistort(const Eigen::Vector2d& raw) const;

 private:
  /// Distorts normalised coordinates; `jacobian` (if not null) gets d(out)/d(in).
  Eigen::Vector2d DistortNormalised(const Eigen::Vector2d& xy,
                                    Eigen::Matrix2d* jacobian) const;

  LensParameters params_;
};

/// A homography and how well it fits its reference points.
struct HomographyFit {
  Eigen::Matrix3d h = Eigen::Matrix3d::Identity();  ///< Maps [u v 1] to [X Y 1]·w.
  double rms_error = 0;               ///< RMS distance of mapped vs given points [target units].
  double max_error = 0;               ///< Largest such distance [target units].
  std::vector<double> residuals;      ///< Each point's distance [target units].
};

/// Applies homography `h` to the 2-D point `p` (dehomogenised).
Eigen::Vector2d ApplyHomography(const Eigen::Matrix3d& h, const Eigen::Vector2d& p);

/// Normalised-DLT homography mapping `from[i]` to `to[i]` (Eigen SVD);
/// INVALID_ARGUMENT for sizes that differ, fewer than 4 points, non-finite
/// coordinates, or a degenerate (e.g. collinear) configuration.
HomographyFit FitHomography(const std::vector<Eigen::Vector2d>& from,
                            const std::vector<Eigen::Vector2d>& to);

/// A calibration reference point: raw pixel where the LED was seen at `ground`.
struct ReferencePoint {
  Eigen::Vector2d pixel;   ///< Raw pixel as CamApp reports it [px].
  Eigen::Vector2d ground;  ///< Position on the ground [m].
  int line = 0;            ///< Line of the calibration file it came from (0: none).
};

/// Everything a calibration file holds (docs/camapp.md, "Calibration file").
struct CameraCalibration {
  LensParameters lens;                  ///< The lens.
  double led_height = 0;                ///< LED height above ground [m] (informational).
  std::vector<ReferencePoint> points;   ///< At least 4 reference points.
};

/// Parses calibration text; `name` (the file name) prefixes every error as
/// "name:line: ..." (INVALID_ARGUMENT). Does not fit the homography.
CameraCalibration ParseCameraCalibration(std::string_view text, std::string_view name);

/// Parses a file of reference points only (`yamorctl calibrate`): one point
/// per line, `x y X Y` (raw pixel, metres on the ground), optionally after
/// the word `point`; `#` comments and blank lines as in a calibration file.
/// INVALID_ARGUMENT "name:line: ..." for anything else.
std::vector<ReferencePoint> ParseReferencePoints(std::string_view text, std::string_view name);

/// A calibration file's text for `calibration` (every number written so it
/// reads back exactly), after `comment` lines (each prefixed with "# ").
std::string FormatCameraCalibration(const CameraCalibration& calibration, std::string_view comment);

/// The camera: raw pixels -> metres on the ground plane at the LED's height.
/// Thread-safety: immutable after construction; safe to share between threads.
class CameraModel {
 public:
  /// Validates the lens and fits the homography to the undistorted reference
  /// points; INVALID_ARGUMENT naming `name` and the lines of the points when
  /// they are too few or degenerate.
  CameraModel(const CameraCalibration& calibration, std::string_view name = "calibration");

  /// The lens.
  const LensModel& lens() const noexcept { return lens_; }
  /// The homography fit (undistorted pixels -> metres) and its reprojection error.
  const HomographyFit& fit() const noexcept { return fit_; }
  /// LED height above the ground the model is calibrated for [m].
  double led_height() const noexcept { return led_height_; }

  /// Metres on the ground for raw pixel `raw`; OUT_OF_RANGE when `raw` is
  /// outside the image or cannot be undistorted.
  Eigen::Vector2d PixelToGround(const Eigen::Vector2d& raw) const;

  /// Raw pixel at which a point at `ground` metres appears (may lie outside the image).
  Eigen::Vector2d GroundToPixel(const Eigen::Vector2d& ground) const;

 private:
  LensModel lens_;
  HomographyFit fit_;
  Eigen::Matrix3d inverse_h_;
  double led_height_;
};

/// Reads and parses the calibration file at `path` and builds the model;
/// NOT_FOUND when it cannot be read, INVALID_ARGUMENT "path:line: ..." otherwise.
/// Logs the reprojection error.
CameraModel LoadCameraModel(const std::filesystem::path& path);

}  // namespace yamor::host
