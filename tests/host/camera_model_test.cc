// The LED tracker's camera model: Brown–Conrady inverse over the whole image,
// the ground homography on a synthetic ceiling camera (thesis 4.2.1: 2.7 m
// above the ground, 640x480), reprojection error with noise, bad calibrations.
#include "host/camera_model.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <unistd.h>  // getpid

#include "common/format.h"
#include "common/status.h"

namespace yamor::host {
namespace {

using ::testing::HasSubstr;

// Realistic barrel distortion of a wide-angle 640x480 camera.
LensParameters RealisticLens() {
  LensParameters p;
  p.fx = 520;
  p.fy = 518;
  p.cx = 322.5;
  p.cy = 237.0;
  p.k1 = -0.28;
  p.k2 = 0.09;
  p.k3 = -0.012;
  p.p1 = 0.0004;
  p.p2 = -0.0002;
  return p;
}

constexpr double kCameraHeight = 2.7;  // thesis 4.2.1
constexpr double kLedHeight = 0.06;

// A ceiling camera looking down, slightly tilted and turned, over (0.1, -0.05).
struct SyntheticCamera {
  LensParameters lens = RealisticLens();
  Eigen::Matrix3d rotation;  // world -> camera
  Eigen::Vector3d centre{0.1, -0.05, kCameraHeight};

  SyntheticCamera() {
    Eigen::Matrix3d down;  // camera x = world X, y = -Y, z = -Z (looking down)
    down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
    const Eigen::Matrix3d tilt =
        (Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(-0.02, Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitZ())).toRotationMatrix();
    rotation = tilt * down;
  }
  // Ideal (pinhole) pixel of a point on the plane at LED height.
  Eigen::Vector2d Ideal(const Eigen::Vector2d& ground) const {
    const Eigen::Vector3d pc = rotation * (Eigen::Vector3d(ground.x(), ground.y(), kLedHeight) - centre);
    return {lens.fx * pc.x() / pc.z() + lens.cx, lens.fy * pc.y() / pc.z() + lens.cy};
  }
  bool Inside(const Eigen::Vector2d& px) const {
    return px.x() >= 0 && px.x() <= lens.width - 1 && px.y() >= 0 && px.y() <= lens.height - 1;
  }
};

// Reference points on a 20-cm grid that the camera sees, raw pixels exact.
CameraCalibration SyntheticCalibration(const SyntheticCamera& cam, const LensModel& lens,
                                       double noise_px = 0, unsigned seed = 1) {
  CameraCalibration cal;
  cal.lens = cam.lens;
  cal.led_height = kLedHeight;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, noise_px);
  int line = 10;
  for (double x = -1.6; x <= 1.6; x += 0.2) {
    for (double y = -1.2; y <= 1.2; y += 0.2) {
      Eigen::Vector2d raw = lens.Distort(cam.Ideal({x, y}));
      if (noise_px > 0) raw += Eigen::Vector2d(noise(rng), noise(rng));
      if (!cam.Inside(raw)) continue;
      cal.points.push_back({raw, {x, y}, line++});
    }
  }
  return cal;
}

TEST(LensModelTest, InverseOfForwardWithin1e6PxOverTheWholeImage) {
  const LensModel lens(RealisticLens());
  double worst = 0;
  for (int v = 0; v < 480; ++v) {
    for (int u = 0; u < 640; ++u) {
      for (const Eigen::Vector2d& raw : {Eigen::Vector2d(u, v), Eigen::Vector2d(u + 0.37, v + 0.61)}) {
        if (raw.x() > 639 || raw.y() > 479) continue;
        const Eigen::Vector2d ideal = lens.Undistort(raw);
        worst = std::max(worst, (lens.Distort(ideal) - raw).norm());
      }
    }
  }
  RecordProperty("max_roundtrip_error_px", FormatRounded(worst));
  EXPECT_LT(worst, 1e-6);
  // Barrel: the corner's ideal pixel lies farther from the centre than the raw one.
  const Eigen::Vector2d corner(0, 0), centre(322.5, 237.0);
  EXPECT_GT((lens.Undistort(corner) - centre).norm(), (corner - centre).norm() + 20);
}

TEST(LensModelTest, ForwardMatchesTheDocumentedFormula) {
  LensParameters p;
  p.fx = 500;
  p.fy = 400;
  p.cx = 300;
  p.cy = 200;
  p.k1 = 0.1;
  p.k2 = 0.01;
  p.k3 = 0.001;
  p.p1 = 0.002;
  p.p2 = 0.003;
  const LensModel lens(p);
  // By hand from docs/camapp.md: x = y = 0.2, r² = 0.08, radial = 1.008064512,
  // x_d = 0.2016129024 + 0.00016 + 0.00048, y_d = 0.2016129024 + 0.00032 + 0.00024.
  const Eigen::Vector2d raw = lens.Distort({400, 280});
  EXPECT_NEAR(raw.x(), 401.1264512, 1e-9);
  EXPECT_NEAR(raw.y(), 280.86916096, 1e-9);
  EXPECT_LT((lens.Undistort({401.1264512, 280.86916096}) - Eigen::Vector2d(400, 280)).norm(), 1e-9);
}

TEST(LensModelTest, ForwardOfInverseRecoversIdealPixels) {
  const LensModel lens(RealisticLens());
  double worst = 0;
  for (double v = -40; v <= 520; v += 7.3) {
    for (double u = -60; u <= 700; u += 9.1) {
      const Eigen::Vector2d ideal(u, v);
      worst = std::max(worst, (lens.Undistort(lens.Distort(ideal)) - ideal).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(LensModelTest, NonConvergenceIsAnErrorNotAWrongAnswer) {
  const LensModel lens(RealisticLens());
  // Beyond the radius where r(1 + k1 r² + ...) turns back: no inverse exists.
  try {
    lens.Undistort({322.5 + 2000, 237});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kOutOfRange);
    EXPECT_THAT(e.what(), HasSubstr("2322.5"));
  }
}

TEST(LensModelTest, CoefficientsThatFoldTheImageAreRejected) {
  LensParameters p = RealisticLens();
  p.fx = p.fy = 300;
  p.k1 = -1.0;
  p.k2 = p.k3 = 0;
  try {
    LensModel lens(p);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(e.what(), HasSubstr("k1 -1"));
  }
  p = RealisticLens();
  p.fx = -5;
  EXPECT_THROW(LensModel{p}, Error);
  p = RealisticLens();
  p.k2 = std::nan("");
  EXPECT_THROW(LensModel{p}, Error);
}

TEST(HomographyTest, ExactOnSyntheticCeilingCamera) {
  const SyntheticCamera cam;
  const LensModel lens(cam.lens);
  const CameraCalibration cal = SyntheticCalibration(cam, lens);
  ASSERT_GE(cal.points.size(), 100u);
  const CameraModel model(cal, "synthetic");
  EXPECT_LT(model.fit().max_error, 1e-9);
  EXPECT_LT(model.fit().rms_error, 1e-9);
  // Points off the grid, over the whole visible floor.
  double worst = 0, worst_px = 0;
  for (double x = -1.55; x <= 1.55; x += 0.0731) {
    for (double y = -1.15; y <= 1.15; y += 0.0613) {
      const Eigen::Vector2d raw = lens.Distort(cam.Ideal({x, y}));
      if (!cam.Inside(raw)) continue;
      worst = std::max(worst, (model.PixelToGround(raw) - Eigen::Vector2d(x, y)).norm());
      worst_px = std::max(worst_px, (model.GroundToPixel({x, y}) - raw).norm());
    }
  }
  RecordProperty("max_ground_error_m", FormatRounded(worst));
  EXPECT_LT(worst, 1e-9);
  EXPECT_LT(worst_px, 1e-6);
}

TEST(HomographyTest, WithoutDistortionCorrectionPositionsAreCentimetresOff) {
  const SyntheticCamera cam;
  const LensModel lens(cam.lens);
  const CameraCalibration cal = SyntheticCalibration(cam, lens);
  std::vector<Eigen::Vector2d> raw, ground;
  for (const auto& p : cal.points) {
    raw.push_back(p.pixel);
    ground.push_back(p.ground);
  }
  const HomographyFit uncorrected = FitHomography(raw, ground);  // raw pixels, no lens
  const CameraModel corrected(cal, "synthetic");
  RecordProperty("uncorrected_rms_mm", FormatRounded(uncorrected.rms_error * 1e3));
  RecordProperty("uncorrected_max_mm", FormatRounded(uncorrected.max_error * 1e3));
  EXPECT_GT(uncorrected.max_error, 0.02);  // the reason the correction exists
  EXPECT_LT(corrected.fit().max_error, 1e-9);
}

TEST(HomographyTest, FourPointsDetermineIt) {
  const Eigen::Matrix3d truth = (Eigen::Matrix3d() << 0.005, 0.0002, -1.6, -0.0001, -0.0051, 1.2,
                                 1e-6, -2e-6, 1).finished();
  std::vector<Eigen::Vector2d> from = {{10, 12}, {630, 20}, {600, 470}, {25, 460}}, to;
  for (const auto& p : from) to.push_back(ApplyHomography(truth, p));
  const HomographyFit fit = FitHomography(from, to);
  EXPECT_LT(fit.max_error, 1e-12);
  const Eigen::Vector2d q(333, 111);
  EXPECT_LT((ApplyHomography(fit.h, q) - ApplyHomography(truth, q)).norm(), 1e-10);
}

TEST(HomographyTest, ReprojectionErrorReportedForNoisyPoints) {
  const SyntheticCamera cam;
  const LensModel lens(cam.lens);
  const CameraCalibration noisy = SyntheticCalibration(cam, lens, /*noise_px=*/0.5, /*seed=*/7);
  const CameraModel model(noisy, "noisy");
  const HomographyFit& fit = model.fit();
  ASSERT_EQ(fit.residuals.size(), noisy.points.size());
  double sum_sq = 0, max = 0;
  for (double r : fit.residuals) {
    sum_sq += r * r;
    max = std::max(max, r);
  }
  EXPECT_DOUBLE_EQ(fit.rms_error, std::sqrt(sum_sq / fit.residuals.size()));
  EXPECT_DOUBLE_EQ(fit.max_error, max);
  // 0.5 px at 2.64 m / 520 px ≈ 2.5 mm per axis: RMS a few mm, never zero.
  EXPECT_GT(fit.rms_error, 0.5e-3);
  EXPECT_LT(fit.rms_error, 5e-3);
  RecordProperty("noisy_rms_mm", FormatRounded(fit.rms_error * 1e3));
  RecordProperty("noisy_max_mm", FormatRounded(fit.max_error * 1e3));
  // The averaged fit predicts true positions better than one noisy sample.
  double sum_true = 0;
  int n = 0;
  for (double x = -1.5; x <= 1.5; x += 0.1) {
    for (double y = -1.1; y <= 1.1; y += 0.1) {
      const Eigen::Vector2d raw = lens.Distort(cam.Ideal({x, y}));
      if (!cam.Inside(raw)) continue;
      sum_true += (model.PixelToGround(raw) - Eigen::Vector2d(x, y)).squaredNorm();
      ++n;
    }
  }
  const double rms_true = std::sqrt(sum_true / n);
  RecordProperty("noisy_fit_true_rms_mm", FormatRounded(rms_true * 1e3));
  EXPECT_LT(rms_true, fit.rms_error);
}

TEST(HomographyTest, DegenerateConfigurationsRejected) {
  std::vector<Eigen::Vector2d> line = {{0, 0}, {1, 1}, {2, 2}, {3, 3}, {4, 4}};
  std::vector<Eigen::Vector2d> square = {{0, 0}, {1, 0}, {1, 1}, {0, 1}, {0.5, 0.2}};
  EXPECT_THROW(FitHomography(line, square), Error);
  EXPECT_THROW(FitHomography(square, line), Error);
  // Three of four on one line.
  std::vector<Eigen::Vector2d> three = {{0, 0}, {1, 0}, {2, 0}, {0, 1}};
  std::vector<Eigen::Vector2d> four = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  try {
    FitHomography(three, four);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
    EXPECT_THAT(e.what(), HasSubstr("do not determine"));
  }
  EXPECT_THROW(FitHomography({{0, 0}, {1, 0}, {1, 1}}, {{0, 0}, {1, 0}, {1, 1}}), Error);
}

constexpr const char* kHeader =
    "# ceiling camera\n"
    "image 640 480\n"
    "focal 520 518   # px\n"
    "principal 322.5 237\n"
    "radial -0.28 0.09 -0.012\n"
    "tangential 0.0004 -0.0002\n"
    "led_height 0.06\n";

std::string Message(const std::string& text) {
  try {
    CameraModel(ParseCameraCalibration(text, "cal.txt"), "cal.txt");
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kInvalidArgument) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "accepted:\n" << text;
  return "";
}

TEST(CalibrationFileTest, ParsesTheDocumentedFormat) {
  const CameraCalibration cal = ParseCameraCalibration(
      std::string(kHeader) +
          "point 100 100 -1 -1\n\npoint 540 100 1 -1\npoint 540 380 1 1\r\npoint 100 380 -1 1\n"
          "point 320.5 240 0 0",
      "cal.txt");
  EXPECT_EQ(cal.lens.width, 640);
  EXPECT_DOUBLE_EQ(cal.lens.fy, 518);
  EXPECT_DOUBLE_EQ(cal.lens.k3, -0.012);
  EXPECT_DOUBLE_EQ(cal.lens.p2, -0.0002);
  EXPECT_DOUBLE_EQ(cal.led_height, 0.06);
  ASSERT_EQ(cal.points.size(), 5u);
  EXPECT_EQ(cal.points[1].line, 10);
  EXPECT_EQ(cal.points[4].pixel, Eigen::Vector2d(320.5, 240));
  const CameraModel model(cal, "cal.txt");
  EXPECT_NEAR(model.PixelToGround({320.5, 240}).norm(), 0, 0.05);
}

TEST(CalibrationFileTest, TheExampleInTheDocsLoads) {
  std::ifstream in(std::string(YAMOR_SOURCE_DIR) + "/docs/camapp.md");
  ASSERT_TRUE(in);
  std::stringstream doc;
  doc << in.rdbuf();
  const std::string text = doc.str();
  const size_t begin = text.find("# ceiling camera, lab B");
  ASSERT_NE(begin, std::string::npos);
  const size_t end = text.find("```", begin);
  ASSERT_NE(end, std::string::npos);
  const CameraModel model(ParseCameraCalibration(text.substr(begin, end - begin), "docs/camapp.md"),
                          "docs/camapp.md");
  EXPECT_EQ(model.fit().residuals.size(), 5u);
  EXPECT_LT(model.fit().rms_error, 0.05);
}

TEST(CalibrationFileTest, FewerThanFourPointsNamesFileAndLines) {
  EXPECT_THAT(Message(std::string(kHeader) + "point 100 100 -1 -1\npoint 540 100 1 -1\npoint 540 380 1 1\n"),
              HasSubstr("cal.txt:8,9,10: 3 reference points"));
  EXPECT_THAT(Message(kHeader), HasSubstr("cal.txt:0: 0 reference points"));
}

TEST(CalibrationFileTest, CollinearPointsNamesFileAndLines) {
  EXPECT_THAT(Message(std::string(kHeader) +
                      "point 100 100 0 0\npoint 200 200 1 1\npoint 300 300 2 2\npoint 400 400 3 3\n"),
              AllOf(HasSubstr("cal.txt:8,9,10,11:"), HasSubstr("collinear")));
  EXPECT_THAT(Message(std::string(kHeader) +
                      "point 100 100 0 0\npoint 200 100 1 0\npoint 300 100 2 0\npoint 100 300 0 1\n"),
              HasSubstr("cal.txt:8,9,10,11:"));
}

TEST(CalibrationFileTest, NanAndMalformedValuesNameTheLine) {
  EXPECT_THAT(Message(std::string(kHeader) + "point 100 100 -1 -1\npoint 540 nan 1 -1\n"),
              AllOf(HasSubstr("cal.txt:9:"), HasSubstr("\"nan\"")));
  EXPECT_THAT(Message("image 640 480\nfocal nan 500\n"), HasSubstr("cal.txt:2: focal: fx"));
  EXPECT_THAT(Message("image 640 480\nfocal 500 500\nprincipal 320 inf\n"), HasSubstr("cal.txt:3:"));
  EXPECT_THAT(Message("image 640 480\nfocal 500 500 3\n"), HasSubstr("cal.txt:2: focal: expected 2"));
  EXPECT_THAT(Message("image 640.5 480\n"), HasSubstr("cal.txt:1: image: width"));
  EXPECT_THAT(Message(std::string(kHeader) + "zoom 2\n"), HasSubstr("cal.txt:8: unknown directive \"zoom\""));
  EXPECT_THAT(Message(std::string(kHeader) + "radial 0 0 0\n"), HasSubstr("cal.txt:8: radial appears twice"));
  EXPECT_THAT(Message("image 640 480\nprincipal 320 240\n"), HasSubstr("missing `focal"));
  EXPECT_THAT(Message(std::string(kHeader) +
                      "point 100 100 -1 -1\npoint 540 100 1 -1\npoint 700 380 1 1\npoint 100 380 -1 1\n"),
              AllOf(HasSubstr("cal.txt:10:"), HasSubstr("outside")));
  EXPECT_THAT(Message("image 640 480\nfocal 500 500\nprincipal 900 240\n"), HasSubstr("principal point"));
}

TEST(CalibrationFileTest, LoadFromFile) {
  const auto dir = std::filesystem::temp_directory_path() / ("yamor_cal_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = dir / "camera.txt";
  const SyntheticCamera cam;
  const LensModel lens(cam.lens);
  {
    std::ofstream out(path);
    out << kHeader;
    out.precision(17);
    for (const auto& p : SyntheticCalibration(cam, lens).points) {
      out << "point " << p.pixel.x() << " " << p.pixel.y() << " " << p.ground.x() << " " << p.ground.y() << "\n";
    }
  }
  const CameraModel model = LoadCameraModel(path);
  EXPECT_LT(model.fit().max_error, 1e-9);
  EXPECT_DOUBLE_EQ(model.led_height(), 0.06);
  try {
    LoadCameraModel(dir / "missing.txt");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kNotFound);
    EXPECT_THAT(e.what(), HasSubstr("missing.txt"));
  }
  {
    std::ofstream out(path);
    out << kHeader << "point 1 2 3\n";
  }
  try {
    LoadCameraModel(path);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr(path.string() + ":8: point: expected 4"));
  }
  std::filesystem::remove_all(dir);
}

TEST(CameraModelTest, PixelOutsideTheImageIsOutOfRange) {
  const SyntheticCamera cam;
  const LensModel lens(cam.lens);
  const CameraModel model(SyntheticCalibration(cam, lens), "synthetic");
  try {
    model.PixelToGround({640, 10});
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kOutOfRange);
    EXPECT_THAT(e.what(), HasSubstr("(640, 10)"));
  }
}

TEST(CalibrationFileTest, FormattedCalibrationReadsBackExactly) {
  const SyntheticCamera cam;
  const LensModel lens(cam.lens);
  CameraCalibration cal = SyntheticCalibration(cam, lens);
  cal.led_height = 0.0625;
  const std::string text = FormatCameraCalibration(cal, "two\ncomment lines");
  EXPECT_EQ(text.rfind("# two\n# comment lines\nimage ", 0), 0u) << text;
  const CameraCalibration back = ParseCameraCalibration(text, "formatted");
  EXPECT_EQ(back.lens.k1, cal.lens.k1);
  EXPECT_EQ(back.lens.p2, cal.lens.p2);
  EXPECT_EQ(back.led_height, 0.0625);
  ASSERT_EQ(back.points.size(), cal.points.size());
  for (size_t i = 0; i < cal.points.size(); ++i) {
    EXPECT_EQ(back.points[i].pixel, cal.points[i].pixel) << "bit for bit";
    EXPECT_EQ(back.points[i].ground, cal.points[i].ground);
  }
}

TEST(CalibrationFileTest, ReferencePointsFileNamesTheBadLine) {
  const auto points = ParseReferencePoints("# x y X Y\n10 20 -1 0.5\n\npoint 30.5 40 1 -0.5  # a comment\n",
                                           "points.txt");
  ASSERT_EQ(points.size(), 2u);
  EXPECT_EQ(points[0].pixel, Eigen::Vector2d(10, 20));
  EXPECT_EQ(points[1].ground, Eigen::Vector2d(1, -0.5));
  EXPECT_EQ(points[1].line, 4);
  for (const auto& [text, expected] : std::vector<std::pair<std::string, std::string>>{
           {"1 2 3\n", "points.txt:1: expected a reference point"},
           {"1 2 3 4\n1 2 nan 4\n", "points.txt:2: X must be a finite number, got \"nan\""},
           {"image 640 480\n", "points.txt:1: expected a reference point"}}) {
    try {
      ParseReferencePoints(text, "points.txt");
      ADD_FAILURE() << "no error for " << text;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), StatusCode::kInvalidArgument);
      EXPECT_THAT(e.what(), HasSubstr(expected));
    }
  }
}

}  // namespace
}  // namespace yamor::host
