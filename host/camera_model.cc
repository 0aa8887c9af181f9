#include "host/camera_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "common/format.h"
#include "common/log.h"
#include "common/status.h"

namespace yamor::host {
namespace {

constexpr double kUndistortTolerancePx = 1e-9;
constexpr int kUndistortMaxIterations = 100;

Error Invalid(const std::string& message) {
  return Error(StatusCode::kInvalidArgument, message);
}

std::string Fmt(double v) {
  std::ostringstream out;
  out.precision(10);
  out << v;
  return out.str();
}

std::string FmtPoint(const Eigen::Vector2d& p) {
  return "(" + Fmt(p.x()) + ", " + Fmt(p.y()) + ")";
}

// Hartley normalisation: centroid to the origin, mean distance sqrt(2).
Eigen::Matrix3d NormalisingTransform(const std::vector<Eigen::Vector2d>& pts) {
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (const auto& p : pts) centroid += p;
  centroid /= static_cast<double>(pts.size());
  double mean_distance = 0;
  for (const auto& p : pts) mean_distance += (p - centroid).norm();
  mean_distance /= static_cast<double>(pts.size());
  if (!(mean_distance > 0)) throw Invalid("homography: all reference points coincide");
  const double s = std::sqrt(2.0) / mean_distance;
  Eigen::Matrix3d t;
  t << s, 0, -s * centroid.x(), 0, s, -s * centroid.y(), 0, 0, 1;
  return t;
}

// True when the points (already normalised) lie on one line.
bool Collinear(const std::vector<Eigen::Vector2d>& pts, const Eigen::Matrix3d& t) {
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const auto& p : pts) {
    const Eigen::Vector2d q = (t * p.homogeneous()).hnormalized();
    scatter += q * q.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(scatter);
  const double largest = eig.eigenvalues()(1);
  return !(eig.eigenvalues()(0) > 1e-10 * largest);
}

}  // namespace

LensModel::LensModel(const LensParameters& p) : params_(p) {
  const std::pair<const char*, double> values[] = {
      {"fx", p.fx}, {"fy", p.fy}, {"cx", p.cx}, {"cy", p.cy}, {"k1", p.k1},
      {"k2", p.k2}, {"k3", p.k3}, {"p1", p.p1}, {"p2", p.p2}};
  for (const auto& [name, value] : values) {
    if (!std::isfinite(value)) throw Invalid(std::string("lens: ") + name + " is not finite: " + Fmt(value));
  }
  if (p.width <= 0 || p.height <= 0) {
    throw Invalid("lens: image size must be positive, got " + std::to_string(p.width) + "x" +
                  std::to_string(p.height));
  }
  if (!(p.fx > 0) || !(p.fy > 0)) {
    throw Invalid("lens: focal length must be > 0, got fx " + Fmt(p.fx) + ", fy " + Fmt(p.fy));
  }
  if (p.cx < 0 || p.cx > p.width - 1 || p.cy < 0 || p.cy > p.height - 1) {
    throw Invalid("lens: principal point " + FmtPoint({p.cx, p.cy}) + " is outside the " +
                  std::to_string(p.width) + "x" + std::to_string(p.height) + " image");
  }
  // Every border pixel must be invertible: otherwise the coefficients fold the
  // image over inside it (the radial polynomial turns back before the corners).
  const double w = p.width - 1, h = p.height - 1;
  constexpr int kSteps = 64;
  for (int i = 0; i <= kSteps; ++i) {
    const double f = static_cast<double>(i) / kSteps;
    for (const Eigen::Vector2d& raw : {Eigen::Vector2d(f * w, 0), Eigen::Vector2d(f * w, h),
                                      Eigen::Vector2d(0, f * h), Eigen::Vector2d(w, f * h)}) {
      try {
        Undistort(raw);
      } catch (const Error& e) {
        throw Invalid("lens: the distortion coefficients (k1 " + Fmt(p.k1) + ", k2 " + Fmt(p.k2) +
                      ", k3 " + Fmt(p.k3) + ", p1 " + Fmt(p.p1) + ", p2 " + Fmt(p.p2) +
                      ") are not invertible over the image: " + e.what());
      }
    }
  }
}

Eigen::Vector2d LensModel::DistortNormalised(const Eigen::Vector2d& xy,
                                             Eigen::Matrix2d* jacobian) const {
  const auto& p = params_;
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (p.k1 + r2 * (p.k2 + r2 * p.k3));
  const Eigen::Vector2d out(x * radial + 2 * p.p1 * x * y + p.p2 * (r2 + 2 * x * x),
                            y * radial + p.p1 * (r2 + 2 * y * y) + 2 * p.p2 * x * y);
  if (jacobian != nullptr) {
    const double d_radial = p.k1 + r2 * (2 * p.k2 + 3 * p.k3 * r2);  // d radial / d r²
    const double cross = 2 * x * y * d_radial + 2 * p.p1 * x + 2 * p.p2 * y;
    (*jacobian) << radial + 2 * x * x * d_radial + 2 * p.p1 * y + 6 * p.p2 * x, cross,
        cross, radial + 2 * y * y * d_radial + 6 * p.p1 * y + 2 * p.p2 * x;
  }
  return out;
}

Eigen::Vector2d LensModel::Distort(const Eigen::Vector2d& ideal) const {
  const auto& p = params_;
  const Eigen::Vector2d xy((ideal.x() - p.cx) / p.fx, (ideal.y() - p.cy) / p.fy);
  const Eigen::Vector2d d = DistortNormalised(xy, nullptr);
  return {p.fx * d.x() + p.cx, p.fy * d.y() + p.cy};
}

Eigen::Vector2d LensModel::Undistort(const Eigen::Vector2d& raw) const {
  const auto& p = params_;
  if (!raw.allFinite()) throw Error(StatusCode::kOutOfRange, "undistort: pixel " + FmtPoint(raw) + " is not finite");
  const Eigen::Vector2d target((raw.x() - p.cx) / p.fx, (raw.y() - p.cy) / p.fy);
  const Eigen::Vector2d scale(p.fx, p.fy);
  // Residual in pixels, the unit of the tolerance.
  auto residual_px = [&](const Eigen::Vector2d& r) { return r.cwiseProduct(scale).norm(); };
  Eigen::Vector2d x = target;
  Eigen::Matrix2d jac;
  Eigen::Vector2d r = DistortNormalised(x, &jac) - target;
  double err = residual_px(r);
  for (int it = 0; it < kUndistortMaxIterations && err > kUndistortTolerancePx; ++it) {
    const double det = jac.determinant();
    if (!(std::abs(det) > 1e-12)) break;
    const Eigen::Vector2d step = jac.inverse() * r;
    // Backtracking: halve the Newton step until the residual decreases.
    double alpha = 1;
    bool improved = false;
    for (int k = 0; k < 30; ++k) {
      const Eigen::Vector2d candidate = x - alpha * step;
      Eigen::Matrix2d cand_jac;
      const Eigen::Vector2d cand_r = DistortNormalised(candidate, &cand_jac) - target;
      const double cand_err = residual_px(cand_r);
      if (cand_err < err) {
        x = candidate;
        r = cand_r;
        jac = cand_jac;
        err = cand_err;
        improved = true;
        break;
      }
      alpha /= 2;
    }
    if (!improved) break;
  }
  // A root where the map folds over (negative Jacobian) is the wrong branch.
  if (!(err <= kUndistortTolerancePx) || !(jac.determinant() > 0)) {
    throw Error(StatusCode::kOutOfRange,
                "undistort: no converged inverse for pixel " + FmtPoint(raw) + " (residual " +
                    Fmt(err) + " px, Jacobian determinant " + Fmt(jac.determinant()) + ")");
  }
  return {p.fx * x.x() + p.cx, p.fy * x.y() + p.cy};
}

Eigen::Vector2d ApplyHomography(const Eigen::Matrix3d& h, const Eigen::Vector2d& p) {
  return (h * p.homogeneous()).hnormalized();
}

HomographyFit FitHomography(const std::vector<Eigen::Vector2d>& from,
                            const std::vector<Eigen::Vector2d>& to) {
  if (from.size() != to.size()) {
    throw Invalid("homography: " + std::to_string(from.size()) + " source points but " +
                  std::to_string(to.size()) + " target points");
  }
  if (from.size() < 4) {
    throw Invalid("homography: " + std::to_string(from.size()) +
                  " reference points; at least 4 are needed");
  }
  for (size_t i = 0; i < from.size(); ++i) {
    if (!from[i].allFinite() || !to[i].allFinite()) {
      throw Invalid("homography: reference point " + std::to_string(i) + " " + FmtPoint(from[i]) +
                    " -> " + FmtPoint(to[i]) + " is not finite");
    }
  }
  const Eigen::Matrix3d t_from = NormalisingTransform(from);
  const Eigen::Matrix3d t_to = NormalisingTransform(to);
  if (Collinear(from, t_from)) throw Invalid("homography: the source points are collinear");
  if (Collinear(to, t_to)) throw Invalid("homography: the target points are collinear");

  const Eigen::Index n = static_cast<Eigen::Index>(from.size());
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(std::max<Eigen::Index>(2 * n, 9), 9);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d u = t_from * from[i].homogeneous();
    const Eigen::Vector2d v = (t_to * to[i].homogeneous()).hnormalized();
    a.block<1, 3>(2 * i, 3) = -u.transpose();
    a.block<1, 3>(2 * i, 6) = v.y() * u.transpose();
    a.block<1, 3>(2 * i + 1, 0) = u.transpose();
    a.block<1, 3>(2 * i + 1, 6) = -v.x() * u.transpose();
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeFullV);
  const Eigen::VectorXd& s = svd.singularValues();
  // A unique solution needs a one-dimensional null space.
  if (!(s(7) > 1e-8 * s(0))) {
    throw Invalid("homography: the reference points do not determine a homography (e.g. three of "
                  "four on one line; singular value ratio " + Fmt(s(7) / s(0)) + ")");
  }
  const Eigen::VectorXd hv = svd.matrixV().col(8);
  Eigen::Matrix3d hn;
  hn << hv(0), hv(1), hv(2), hv(3), hv(4), hv(5), hv(6), hv(7), hv(8);
  // A singular solution (hv has unit norm) maps the plane onto a line.
  if (!hn.allFinite() || !(std::abs(hn.determinant()) > 1e-10)) {
    throw Invalid("homography: the reference points do not determine a homography (the fit is "
                  "singular, e.g. three of four on one line; determinant " + Fmt(hn.determinant()) + ")");
  }
  HomographyFit fit;
  fit.h = t_to.inverse() * hn * t_from;
  fit.h /= fit.h.norm();
  if (fit.h(2, 2) < 0) fit.h = -fit.h;
  double sum_sq = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double e = (ApplyHomography(fit.h, from[i]) - to[i]).norm();
    fit.residuals.push_back(e);
    sum_sq += e * e;
    fit.max_error = std::max(fit.max_error, e);
  }
  fit.rms_error = std::sqrt(sum_sq / static_cast<double>(n));
  return fit;
}

namespace {

std::string LinesOf(const std::vector<ReferencePoint>& points) {
  std::string out;
  for (const auto& p : points) {
    if (!out.empty()) out += ",";
    out += std::to_string(p.line);
  }
  return out;
}

}  // namespace

CameraModel::CameraModel(const CameraCalibration& calibration, std::string_view name)
    : lens_([&] {
        try {
          return LensModel(calibration.lens);
        } catch (const Error& e) {
          throw Invalid(std::string(name) + ": " + e.what());
        }
      }()),
      led_height_(calibration.led_height) {
  const auto& points = calibration.points;
  const std::string where = std::string(name) + ":" + LinesOf(points) + ": ";
  if (points.size() < 4) {
    throw Invalid(std::string(name) + ":" + (points.empty() ? std::string("0") : LinesOf(points)) +
                  ": " + std::to_string(points.size()) +
                  " reference points; at least 4 `point` lines are needed");
  }
  if (!std::isfinite(led_height_)) throw Invalid(std::string(name) + ": led_height is not finite");
  std::vector<Eigen::Vector2d> ideal, ground;
  for (const auto& p : points) {
    const std::string at = std::string(name) + ":" + std::to_string(p.line) + ": ";
    if (!p.pixel.allFinite() || !p.ground.allFinite()) {
      throw Invalid(at + "point " + FmtPoint(p.pixel) + " -> " + FmtPoint(p.ground) + " is not finite");
    }
    const auto& l = calibration.lens;
    if (p.pixel.x() < 0 || p.pixel.x() > l.width - 1 || p.pixel.y() < 0 || p.pixel.y() > l.height - 1) {
      throw Invalid(at + "point pixel " + FmtPoint(p.pixel) + " is outside the " +
                    std::to_string(l.width) + "x" + std::to_string(l.height) + " image");
    }
    try {
      ideal.push_back(lens_.Undistort(p.pixel));
    } catch (const Error& e) {
      throw Invalid(at + e.what());
    }
    ground.push_back(p.ground);
  }
  try {
    fit_ = FitHomography(ideal, ground);
  } catch (const Error& e) {
    throw Invalid(where + e.what());
  }
  inverse_h_ = fit_.h.inverse();
}

Eigen::Vector2d CameraModel::PixelToGround(const Eigen::Vector2d& raw) const {
  const auto& l = lens_.params();
  if (!(raw.x() >= 0 && raw.x() <= l.width - 1 && raw.y() >= 0 && raw.y() <= l.height - 1)) {
    throw Error(StatusCode::kOutOfRange, "camera: pixel " + FmtPoint(raw) + " is outside the " +
                                             std::to_string(l.width) + "x" +
                                             std::to_string(l.height) + " image");
  }
  return ApplyHomography(fit_.h, lens_.Undistort(raw));
}

Eigen::Vector2d CameraModel::GroundToPixel(const Eigen::Vector2d& ground) const {
  return lens_.Distort(ApplyHomography(inverse_h_, ground));
}

namespace {

std::vector<std::string> Fields(std::string_view line) {
  std::vector<std::string> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    size_t j = i;
    while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != '\r') ++j;
    if (j > i) out.emplace_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

}  // namespace

CameraCalibration ParseCameraCalibration(std::string_view text, std::string_view name) {
  CameraCalibration cal;
  bool seen_image = false, seen_focal = false, seen_principal = false;
  std::vector<std::string> seen;
  int line_no = 0;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (const size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    const auto f = Fields(line);
    if (f.empty()) {
      if (end == text.size()) break;
      continue;
    }
    const std::string at = std::string(name) + ":" + std::to_string(line_no) + ": ";
    const std::string& directive = f[0];
    auto expect = [&](size_t count, const char* what) {
      if (f.size() != count + 1) {
        throw Invalid(at + directive + ": expected " + std::to_string(count) + " values (" + what +
                      "), got " + std::to_string(f.size() - 1));
      }
    };
    auto number = [&](size_t i, const char* what) {
      const std::string& tok = f[i];
      char* stop = nullptr;
      errno = 0;
      const double v = std::strtod(tok.c_str(), &stop);
      if (stop == tok.c_str() || *stop != '\0' || errno == ERANGE || !std::isfinite(v)) {
        throw Invalid(at + directive + ": " + what + " must be a finite number, got \"" + tok + "\"");
      }
      return v;
    };
    auto integer = [&](size_t i, const char* what) {
      const double v = number(i, what);
      if (v != std::floor(v) || v <= 0 || v > 1e6) {
        throw Invalid(at + directive + ": " + what + " must be a positive integer, got \"" + f[i] + "\"");
      }
      return static_cast<int>(v);
    };
    if (directive != "point") {
      if (std::find(seen.begin(), seen.end(), directive) != seen.end()) {
        throw Invalid(at + directive + " appears twice");
      }
      seen.push_back(directive);
    }
    if (directive == "image") {
      expect(2, "width height");
      cal.lens.width = integer(1, "width");
      cal.lens.height = integer(2, "height");
      seen_image = true;
    } else if (directive == "focal") {
      expect(2, "fx fy");
      cal.lens.fx = number(1, "fx");
      cal.lens.fy = number(2, "fy");
      if (!(cal.lens.fx > 0)) throw Invalid(at + "focal: fx must be > 0, got \"" + f[1] + "\"");
      if (!(cal.lens.fy > 0)) throw Invalid(at + "focal: fy must be > 0, got \"" + f[2] + "\"");
      seen_focal = true;
    } else if (directive == "principal") {
      expect(2, "cx cy");
      cal.lens.cx = number(1, "cx");
      cal.lens.cy = number(2, "cy");
      seen_principal = true;
    } else if (directive == "radial") {
      expect(3, "k1 k2 k3");
      cal.lens.k1 = number(1, "k1");
      cal.lens.k2 = number(2, "k2");
      cal.lens.k3 = number(3, "k3");
    } else if (directive == "tangential") {
      expect(2, "p1 p2");
      cal.lens.p1 = number(1, "p1");
      cal.lens.p2 = number(2, "p2");
    } else if (directive == "led_height") {
      expect(1, "metres");
      cal.led_height = number(1, "height");
    } else if (directive == "point") {
      expect(4, "x y X Y");
      cal.points.push_back({Eigen::Vector2d(number(1, "x"), number(2, "y")),
                            Eigen::Vector2d(number(3, "X"), number(4, "Y")), line_no});
    } else {
      throw Invalid(at + "unknown directive \"" + directive + "\"");
    }
    if (end == text.size()) break;
  }
  const std::string at_end = std::string(name) + ":" + std::to_string(line_no) + ": ";
  if (!seen_image) throw Invalid(at_end + "missing `image <width> <height>`");
  if (!seen_focal) throw Invalid(at_end + "missing `focal <fx> <fy>`");
  if (!seen_principal) throw Invalid(at_end + "missing `principal <cx> <cy>`");
  return cal;
}

std::vector<ReferencePoint> ParseReferencePoints(std::string_view text, std::string_view name) {
  std::vector<ReferencePoint> points;
  int line_no = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (const size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    auto f = Fields(line);
    if (f.empty()) continue;
    if (f[0] == "point") f.erase(f.begin());
    const std::string at = std::string(name) + ":" + std::to_string(line_no) + ": ";
    if (f.size() != 4) {
      throw Invalid(at + "expected a reference point `x y X Y` (pixel, metres), got " +
                    std::to_string(f.size()) + " values");
    }
    double v[4];
    const char* what[4] = {"x", "y", "X", "Y"};
    for (int i = 0; i < 4; ++i) {
      char* stop = nullptr;
      errno = 0;
      v[i] = std::strtod(f[i].c_str(), &stop);
      if (stop == f[i].c_str() || *stop != '\0' || errno == ERANGE || !std::isfinite(v[i])) {
        throw Invalid(at + what[i] + " must be a finite number, got \"" + f[i] + "\"");
      }
    }
    points.push_back({Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]), line_no});
  }
  return points;
}

std::string FormatCameraCalibration(const CameraCalibration& c, std::string_view comment) {
  std::ostringstream out;
  size_t pos = 0;
  while (pos < comment.size()) {
    size_t end = comment.find('\n', pos);
    if (end == std::string_view::npos) end = comment.size();
    out << "# " << comment.substr(pos, end - pos) << "\n";
    pos = end + 1;
  }
  const LensParameters& l = c.lens;
  out << "image " << l.width << " " << l.height << "\n";
  out << "focal " << FormatDouble(l.fx) << " " << FormatDouble(l.fy) << "\n";
  out << "principal " << FormatDouble(l.cx) << " " << FormatDouble(l.cy) << "\n";
  out << "radial " << FormatDouble(l.k1) << " " << FormatDouble(l.k2) << " " << FormatDouble(l.k3) << "\n";
  out << "tangential " << FormatDouble(l.p1) << " " << FormatDouble(l.p2) << "\n";
  out << "led_height " << FormatDouble(c.led_height) << "\n";
  for (const ReferencePoint& p : c.points) {
    out << "point " << FormatDouble(p.pixel.x()) << " " << FormatDouble(p.pixel.y()) << " "
        << FormatDouble(p.ground.x()) << " " << FormatDouble(p.ground.y()) << "\n";
  }
  return out.str();
}

CameraModel LoadCameraModel(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(StatusCode::kNotFound, "camera calibration: cannot read " + path.string());
  std::ostringstream buffer;
  buffer << in.rdbuf();
  const std::string name = path.string();
  CameraModel model(ParseCameraCalibration(buffer.str(), name), name);
  Log().info("camera calibration {}: {} reference points, reprojection error RMS {:.2f} mm, max {:.2f} mm",
             name, model.fit().residuals.size(), model.fit().rms_error * 1e3,
             model.fit().max_error * 1e3);
  return model;
}

}  // namespace yamor::host
