// Pixel tests of the headless renderer on synthetic scenes: colours where the
// camera projects a module, the ground elsewhere, motion by the projected
// amount, bit-identical frames, both backends, several threads.
#include "physics/render/renderer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "common/status.h"
#include "physics/render/image.h"

namespace yamor::render {
namespace {

constexpr int kModuleId = 1;  // blue: {0.20, 0.55, 0.90}

// One module: a 10 cm body cube (its centre at `position`) and a flat
// handle box in front of it.
Scene OneModule(const Eigen::Vector3d& position) {
  Scene scene;
  scene.time = 1.25;
  scene.shape = {
      ShapeBox{.part = ShapePart::kBody, .center = Eigen::Vector3d::Zero(),
               .size = Eigen::Vector3d(0.1, 0.1, 0.1)},
      ShapeBox{.part = ShapePart::kHandle, .center = Eigen::Vector3d(0.02, 0, 0),
               .size = Eigen::Vector3d(0.04, 0.06, 0.02)},
  };
  SceneModule m;
  m.id = kModuleId;
  m.central = true;
  m.body.position = position;
  m.handle.position = position + Eigen::Vector3d(0.07, 0, 0);
  scene.modules.push_back(m);
  return scene;
}

RenderOptions Flat() {
  return RenderOptions{.lighting = false, .edges = false, .grid = false, .shadows = false,
                       .labels = false, .legend = false};
}

Camera FixedCamera() {
  Camera camera;
  camera.kind = CameraKind::kFixed;
  camera.eye = Eigen::Vector3d(0.8, -1.0, 0.7);
  camera.target = Eigen::Vector3d(0.0, 0.0, 0.05);
  return camera;
}

std::array<int, 3> Rgb(const Color& c) {
  return {static_cast<int>(std::lround(c[0] * 255)), static_cast<int>(std::lround(c[1] * 255)),
          static_cast<int>(std::lround(c[2] * 255))};
}

// True when the pixel is within 1 of `c` in every channel.
bool Near(const std::array<uint8_t, 4>& pixel, const Color& c) {
  const std::array<int, 3> want = Rgb(c);
  for (int i = 0; i < 3; ++i) {
    if (std::abs(pixel[i] - want[i]) > 1) return false;
  }
  return true;
}

std::string Describe(const std::array<uint8_t, 4>& p) {
  return fmt::format("({}, {}, {})", p[0], p[1], p[2]);
}

// Centroid of the pixels exactly of colour `c`; count in `n`.
Eigen::Vector2d Centroid(const Image& image, const Color& c, int& n) {
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  n = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (Near(image.At(x, y), c)) {
        sum += Eigen::Vector2d(x + 0.5, y + 0.5);
        ++n;
      }
    }
  }
  return n > 0 ? Eigen::Vector2d(sum / n) : sum;
}

class RenderTest : public ::testing::TestWithParam<Backend> {
 protected:
  void SetUp() override {
    try {
      renderer_ = std::make_unique<Renderer>(GetParam());
    } catch (const Error& e) {
      // OSMesa is gone from Mesa >= 25.1; EGL may lack a software driver.
      GTEST_SKIP() << BackendName(GetParam()) << " unavailable here: " << e.what();
    }
  }
  std::unique_ptr<Renderer> renderer_;
};

TEST_P(RenderTest, ModuleColourAtItsProjectedCentreAndGroundElsewhere) {
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  const Camera camera = FixedCamera();
  const Image image = renderer_->Render(scene, camera, 320, 240, Flat());
  ASSERT_EQ(image.width, 320);
  ASSERT_EQ(image.rgba.size(), 320u * 240u * 4u);
  const View view = ComputeView(camera, scene, 320, 240);
  const Eigen::Vector2d centre = *Project(view, scene.modules[0].body.position);
  // The target is the middle of the image.
  EXPECT_NEAR(Project(view, camera.target)->x(), 160.0, 1e-9);
  EXPECT_NEAR(Project(view, camera.target)->y(), 120.0, 1e-9);
  const auto px = image.At(static_cast<int>(centre.x()), static_cast<int>(centre.y()));
  EXPECT_TRUE(Near(px, ModuleColor(kModuleId))) << Describe(px);
  // A ground point half a metre away, and the sky in the top row.
  const Eigen::Vector2d ground = *Project(view, Eigen::Vector3d(-0.5, 0.3, 0.0));
  const auto gp = image.At(static_cast<int>(ground.x()), static_cast<int>(ground.y()));
  EXPECT_TRUE(Near(gp, kGroundColor)) << Describe(gp);
  // Looking almost level, the top rows show the sky.
  Camera level;
  level.elevation = 0.1;
  const Image horizon = renderer_->Render(scene, level, 320, 240, Flat());
  EXPECT_TRUE(Near(horizon.At(5, 0), kSkyColor)) << Describe(horizon.At(5, 0));
  EXPECT_TRUE(Near(horizon.At(5, 239), kGroundColor)) << Describe(horizon.At(5, 239));
  for (int i = 3; i < static_cast<int>(image.rgba.size()); i += 4) ASSERT_EQ(image.rgba[i], 255);
}

// Sky exactly where a pixel's ray misses the ground square (150 m around the
// view's target) and ground where it meets it, for views from straight down
// to level and from below the ground: the renderer clears the frame to the
// ground colour instead of drawing the ground when the ground fills the
// view, and must not do so when any sky shows.
TEST_P(RenderTest, SkyExactlyWhereRaysMissTheGround) {
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  const int w = 160;
  const int h = 120;
  int views_with_sky = 0;
  int views_without_sky = 0;
  for (const double elevation : {1.5, 1.0, 0.6, 0.45, 0.3, 0.2, 0.12, 0.08, 0.04, 0.0, -0.3}) {
    for (const double distance : {0.8, 4.0, 60.0}) {
      SCOPED_TRACE(fmt::format("elevation {}, distance {}", elevation, distance));
      Camera camera;
      camera.elevation = elevation;
      camera.distance = distance;
      const Image image = renderer_->Render(scene, camera, w, h, Flat());
      const View view = ComputeView(camera, scene, w, h);
      const Eigen::Matrix4d inverse = (view.projection * view.view).inverse();
      const double cx = std::round(view.target.x() * 10.0) / 10.0;
      const double cy = std::round(view.target.y() * 10.0) / 10.0;
      int sky = 0;
      int wrong = 0;
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          const auto p = image.At(x, y);
          if (Near(p, ModuleColor(kModuleId))) continue;
          const double nx = 2.0 * (x + 0.5) / w - 1.0;
          const double ny = 1.0 - 2.0 * (y + 0.5) / h;
          const Eigen::Vector4d a = inverse * Eigen::Vector4d(nx, ny, -1.0, 1.0);
          const Eigen::Vector4d b = inverse * Eigen::Vector4d(nx, ny, 1.0, 1.0);
          const Eigen::Vector3d near = a.head<3>() / a.w();
          const Eigen::Vector3d far = b.head<3>() / b.w();
          bool ground = (near.z() > 0.0) != (far.z() > 0.0);
          if (ground) {
            const Eigen::Vector3d hit = near + near.z() / (near.z() - far.z()) * (far - near);
            ground = std::abs(hit.x() - cx) <= 150.0 && std::abs(hit.y() - cy) <= 150.0;
          }
          if (!ground) ++sky;
          if (!Near(p, ground ? kGroundColor : kSkyColor)) ++wrong;
        }
      }
      // Only pixels on the horizon's line may fall either way.
      EXPECT_LE(wrong, w) << sky << " sky pixels expected";
      (sky > 0 ? views_with_sky : views_without_sky) += 1;
    }
  }
  // Both kinds of view were tried.
  EXPECT_GT(views_with_sky, 5);
  EXPECT_GT(views_without_sky, 5);
}

TEST_P(RenderTest, TopCameraLooksStraightDownWithYUp) {
  const Scene scene = OneModule(Eigen::Vector3d(0.3, 0.2, 0.05));
  Camera camera;
  camera.kind = CameraKind::kTop;
  const Image image = renderer_->Render(scene, camera, 640, 480, Flat());
  const View view = ComputeView(camera, scene, 640, 480);
  const Eigen::Vector2d p = *Project(view, scene.modules[0].body.position);
  EXPECT_GT(p.x(), 320.0);  // +x is right
  EXPECT_LT(p.y(), 240.0);  // +y is up
  EXPECT_TRUE(Near(image.At(static_cast<int>(p.x()), static_cast<int>(p.y())),
                   ModuleColor(kModuleId)));
  // The ceiling camera's view: 2.7 m up, about 3.3 m of floor across 640 px.
  const double metres_per_pixel = 2.7 * 2 * std::tan(kCeilingCameraFov / 2) / 480;
  EXPECT_NEAR(p.x() - 320.0, 0.3 / metres_per_pixel * 2.7 / (2.7 - 0.05), 0.5);
}

TEST_P(RenderTest, MovingTenCentimetresMovesTheImageByTheProjectedAmount) {
  Camera camera;
  camera.kind = CameraKind::kTop;
  camera.height = 1.5;
  const Scene before = OneModule(Eigen::Vector3d(0, 0, 0.05));
  const Scene after = OneModule(Eigen::Vector3d(0.1, 0, 0.05));
  int n_before = 0;
  int n_after = 0;
  const Eigen::Vector2d c0 =
      Centroid(renderer_->Render(before, camera, 320, 240, Flat()), ModuleColor(kModuleId), n_before);
  const Eigen::Vector2d c1 =
      Centroid(renderer_->Render(after, camera, 320, 240, Flat()), ModuleColor(kModuleId), n_after);
  ASSERT_GT(n_before, 100);
  EXPECT_NEAR(n_before, n_after, n_before / 10);  // rasterised at other sub-pixel offsets
  const View view = ComputeView(camera, before, 320, 240);
  const Eigen::Vector2d expected = *Project(view, Eigen::Vector3d(0.1, 0, 0.1)) -
                                   *Project(view, Eigen::Vector3d(0, 0, 0.1));  // top face
  EXPECT_GT(expected.x(), 10.0);
  EXPECT_NEAR((c1 - c0).x(), expected.x(), 0.6);
  EXPECT_NEAR((c1 - c0).y(), expected.y(), 0.6);

  // A perspective view from the side: the body centre's pixel moves by its
  // projection (the nearer face is what shows, so allow a pixel).
  const Camera side = FixedCamera();
  const View side_view = ComputeView(side, before, 320, 240);
  const Eigen::Vector2d p0 = *Project(side_view, before.modules[0].body.position);
  const Eigen::Vector2d p1 = *Project(side_view, after.modules[0].body.position);
  const Image moved = renderer_->Render(after, side, 320, 240, Flat());
  EXPECT_TRUE(Near(moved.At(static_cast<int>(p1.x()), static_cast<int>(p1.y())),
                   ModuleColor(kModuleId)));
  EXPECT_GT((p1 - p0).norm(), 5.0);
}

TEST_P(RenderTest, FramesAreBitIdenticalAcrossRunsAndRenderers) {
  Scene scene = OneModule(Eigen::Vector3d(0.05, -0.02, 0.06));
  scene.modules[0].body.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, 0.5, 1).normalized()));
  scene.boxes.push_back(StaticBox{.pose = {.position = Eigen::Vector3d(-0.3, 0.2, 0.05)},
                                  .size = Eigen::Vector3d(0.2, 0.1, 0.1)});
  Camera camera;  // follow, everything drawn
  const Image a = renderer_->Render(scene, camera, 320, 240);
  const Image b = renderer_->Render(scene, camera, 320, 240);
  EXPECT_TRUE(a == b);
  const Image other_size = renderer_->Render(scene, camera, 64, 48);
  EXPECT_EQ(other_size.width, 64);
  Renderer second(GetParam());
  EXPECT_TRUE(second.Render(scene, camera, 320, 240) == a);
  EXPECT_EQ(EncodePng(a), EncodePng(b));
}

TEST_P(RenderTest, LightingKeepsTheHueShadowsAndGridDarkenTheGround) {
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  const Camera camera = FixedCamera();
  RenderOptions options;
  options.labels = false;
  options.legend = false;
  const Image image = renderer_->Render(scene, camera, 320, 240, options);
  const View view = ComputeView(camera, scene, 320, 240);
  const Eigen::Vector2d centre = *Project(view, scene.modules[0].body.position);
  const auto px = image.At(static_cast<int>(centre.x()), static_cast<int>(centre.y()));
  const Color c = ModuleColor(kModuleId);  // blue-ish: blue dominates
  ASSERT_GT(c[2], c[0]);
  EXPECT_GT(px[2], px[0]) << Describe(px);
  // The shadow falls on the ground beside the body (the light leans to -x, -y).
  const Eigen::Vector2d shadow = *Project(view, Eigen::Vector3d(0.05, 0.08, 0.0));
  const auto sp = image.At(static_cast<int>(shadow.x()), static_cast<int>(shadow.y()));
  const auto ground = Rgb(kGroundColor);
  EXPECT_LT(sp[0], ground[0] - 40) << Describe(sp);
  // A 1 m grid line through the origin, away from the module.
  const Eigen::Vector2d line = *Project(view, Eigen::Vector3d(0.0, 0.6, 0.0));
  const auto lp = image.At(static_cast<int>(line.x()), static_cast<int>(line.y()));
  EXPECT_LT(lp[0], ground[0] - 10) << Describe(lp);
}

// The ground point seen at pixel centre (x + 0.5, y + 0.5), or nullopt when
// the pixel's ray misses the ground (sky).
std::optional<Eigen::Vector3d> GroundAt(const View& view, int x, int y) {
  const Eigen::Matrix4d inverse = (view.projection * view.view).inverse();
  const double nx = 2.0 * (x + 0.5) / view.width - 1.0;
  const double ny = 1.0 - 2.0 * (y + 0.5) / view.height;
  const Eigen::Vector4d a = inverse * Eigen::Vector4d(nx, ny, -1.0, 1.0);
  const Eigen::Vector4d b = inverse * Eigen::Vector4d(nx, ny, 1.0, 1.0);
  const Eigen::Vector3d near = a.head<3>() / a.w();
  const Eigen::Vector3d far = b.head<3>() / b.w();
  if (near.z() <= 0.0 || far.z() >= 0.0) return std::nullopt;
  const double t = near.z() / (near.z() - far.z());
  return Eigen::Vector3d(near + t * (far - near));
}

// How many pixels apart lines `spacing` metres apart appear at ground point
// `p`, in the direction they crowd most: along the line of sight.
double ProjectedSpacing(const View& view, const Eigen::Vector3d& p, double spacing) {
  Eigen::Vector3d away(p.x() - view.eye.x(), p.y() - view.eye.y(), 0.0);
  away.normalize();
  return (*Project(view, p + spacing * away) - *Project(view, p)).norm();
}

// The 10 cm grid is drawn around the robot, where its lines are a few pixels
// apart, and left out farther away (even within 3 m, where the renderer drew
// it before), where they would crowd into a band; the 1 m grid reaches
// farther, by the same rule.
TEST_P(RenderTest, FineGridAroundTheRobotOnlyCoarseGridFarther) {
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  Camera camera;  // the default follow camera, as videos use
  RenderOptions options = Flat();
  options.grid = true;
  for (auto [w, h] : {std::pair{320, 240}, std::pair{640, 480}}) {
    SCOPED_TRACE(fmt::format("{}x{}", w, h));
    const Image image = renderer_->Render(scene, camera, w, h, options);
    const View view = ComputeView(camera, scene, w, h);
    const Eigen::Vector2d foot(view.eye.x(), view.eye.y());
    int fine = 0;
    int coarse = 0;
    int crowded = 0;  // ground pixels within 3 m of the robot where 10 cm lines crowd
    double fine_reach = 0.0;
    double coarse_reach = 0.0;
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const std::optional<Eigen::Vector3d> g = GroundAt(view, x, y);
        if (!g) continue;
        const double reach = (g->head<2>() - foot).norm();
        const double fine_spacing = ProjectedSpacing(view, *g, 0.1);
        if (fine_spacing < 2.0 && g->head<2>().cwiseAbs().maxCoeff() < 2.9) ++crowded;
        const auto p = image.At(x, y);
        if (Near(p, kGridFineColor)) {
          ++fine;
          fine_reach = std::max(fine_reach, reach);
          EXPECT_GE(fine_spacing, kMinGridSpacingPx - 0.5)
              << "a 10 cm line at pixel " << x << ", " << y << " (ground " << g->x() << ", "
              << g->y() << ") where its neighbours are " << fine_spacing << " px away";
        } else if (Near(p, kGridCoarseColor)) {
          ++coarse;
          coarse_reach = std::max(coarse_reach, reach);
          EXPECT_GE(ProjectedSpacing(view, *g, 1.0), kMinGridSpacingPx - 0.5)
              << "a 1 m line at pixel " << x << ", " << y;
        }
      }
    }
    // Lines are there: the 10 cm grid around the robot (0.72 m from the
    // eye's foot point), the 1 m grid reaching at least twice as far.
    EXPECT_GT(fine, 10 * w / 32);
    EXPECT_GT(coarse, 2 * w / 32);
    EXPECT_GT(fine_reach, 1.0);
    EXPECT_GT(coarse_reach, 2.0 * fine_reach);
    // And there was ground where the old 3 m wide 10 cm grid crowded.
    EXPECT_GT(crowded, 100);
    if (HasFailure()) break;
  }
}

TEST_P(RenderTest, LegendAndLabelsShowIdsAndTime) {
  Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  const Camera camera = FixedCamera();
  RenderOptions legend_only = Flat();
  legend_only.legend = true;
  const Image image = renderer_->Render(scene, camera, 320, 240, legend_only);
  // The strip at the bottom: dark, with the module's colour swatch at its left.
  EXPECT_LT(image.At(160, 239)[0], 60);
  EXPECT_TRUE(Near(image.At(3, 233), ModuleColor(kModuleId))) << Describe(image.At(3, 233));
  // White text: the id and the time.
  int white = 0;
  for (int y = 226; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) white += image.At(x, y)[0] == 255 && image.At(x, y)[2] == 255;
  }
  EXPECT_GT(white, 20);
  // Labels change pixels up and right of the centre, not the centre itself.
  RenderOptions labels = Flat();
  labels.labels = true;
  const Image labelled = renderer_->Render(scene, camera, 320, 240, labels);
  const Image plain = renderer_->Render(scene, camera, 320, 240, Flat());
  const View view = ComputeView(camera, scene, 320, 240);
  const Eigen::Vector2d centre = *Project(view, scene.modules[0].body.position);
  EXPECT_EQ(labelled.At(static_cast<int>(centre.x()), static_cast<int>(centre.y())),
            plain.At(static_cast<int>(centre.x()), static_cast<int>(centre.y())));
  EXPECT_FALSE(labelled == plain);
}

// Reads the 3x5 glyph whose top-left font pixel is at (x, y) (scale 1) as
// rows of 3 bits, a bit set where the pixel is `ink`.
std::array<int, 5> ReadGlyph(const Image& image, int x, int y, const std::array<uint8_t, 4>& ink) {
  std::array<int, 5> rows{};
  for (int row = 0; row < 5; ++row) {
    for (int col = 0; col < 3; ++col) {
      if (image.At(x + col, y + row) == ink) rows[row] |= 1 << (2 - col);
    }
  }
  return rows;
}

// The legend's time and the label's id are readable at the pixels the
// layout puts them: every font pixel set or clear, in the text colour,
// against the strip's or the label's background.
TEST_P(RenderTest, TextIsDrawnPixelExactWhereTheLayoutPutsIt) {
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));  // t = 1.25 s, id 1
  const Camera camera = FixedCamera();
  RenderOptions options = Flat();
  options.legend = true;
  options.labels = true;
  const Image image = renderer_->Render(scene, camera, 320, 240, options);
  const std::array<uint8_t, 4> white = {255, 255, 255, 255};
  // The same 3x5 font as the renderer, for the characters drawn here.
  const std::map<char, std::array<int, 5>> font = {
      {'t', {2, 7, 2, 2, 3}}, {'=', {0, 7, 0, 7, 0}}, {'1', {2, 6, 2, 2, 7}},
      {'.', {0, 0, 0, 0, 2}}, {'2', {7, 1, 7, 4, 7}}, {'5', {7, 4, 7, 1, 7}},
      {'s', {3, 4, 2, 1, 6}}};
  // The time at the right of the strip: "t=1.25s" is 7 characters of 4
  // pixels less one, with 2 pixels each side; the strip is one 7-pixel row
  // plus 1 at the bottom.
  const std::string time = "t=1.25s";
  const int time_x = 320 - (7 * 4 - 1 + 4) + 2;
  const int top = 240 - 7 - 1;
  for (std::size_t i = 0; i < time.size(); ++i) {
    EXPECT_EQ(ReadGlyph(image, time_x + 4 * static_cast<int>(i), top + 1, white),
              font.at(time[i]))
        << "character " << i << " '" << time[i] << "'";
  }
  // Left of the time: the module's swatch (5x5) and its id in the LED
  // colour (the central module).
  EXPECT_EQ(image.At(2, top + 1), image.At(6, top + 5));
  EXPECT_TRUE(Near(image.At(2, top + 1), ModuleColor(kModuleId))) << Describe(image.At(2, top + 1));
  EXPECT_EQ(ReadGlyph(image, 2 + 6, top + 1, image.At(2 + 6 + 1, top + 1)), font.at('1'));
  EXPECT_GT(image.At(2 + 6 + 1, top + 1)[0], 200);  // red: the LED's colour
  // The label: a box 3 pixels up and right of the body's projected centre,
  // the id inside it, one pixel in.
  const View view = ComputeView(camera, scene, 320, 240);
  const Eigen::Vector2d centre = *Project(view, scene.modules[0].body.position);
  const int x = static_cast<int>(std::floor(centre.x())) + 3;
  const int y = static_cast<int>(std::floor(centre.y())) - 3 - 7;
  EXPECT_EQ(ReadGlyph(image, x + 1, y + 1, white), font.at('1'));
  const auto box = image.At(x, y);
  EXPECT_EQ(image.At(x + 4, y + 6), box);  // the label is 5 x 7 pixels
  EXPECT_NE(image.At(x + 5, y + 3), box);
  EXPECT_TRUE(Near(box, Color{ModuleColor(kModuleId)[0] * 0.35f, ModuleColor(kModuleId)[1] * 0.35f,
                              ModuleColor(kModuleId)[2] * 0.35f}))
      << Describe(box);
}

// Shadows on the ground are one shade, however many shadow polygons cover
// a pixel, and the ground in the sun keeps its colour.
TEST_P(RenderTest, OverlappingShadowsDarkenTheGroundOnce) {
  Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  SceneModule second = scene.modules[0];
  second.id = 2;
  second.central = false;
  second.body.position = Eigen::Vector3d(0.04, 0.03, 0.16);  // above and beside the first
  second.handle.position = second.body.position + Eigen::Vector3d(0.07, 0, 0);
  scene.modules.push_back(second);
  Camera camera;
  camera.kind = CameraKind::kTop;
  camera.height = 1.0;
  RenderOptions options = Flat();
  options.shadows = true;
  const Image image = renderer_->Render(scene, camera, 320, 240, options);
  const auto ground = Rgb(kGroundColor);
  int shaded = 0;
  std::set<std::array<uint8_t, 4>> shades;
  for (int y = 0; y < 240; ++y) {
    for (int x = 0; x < 320; ++x) {
      const auto p = image.At(x, y);
      if (p[0] < ground[0] - 20 && p[0] > 60 && std::abs(p[0] - p[1]) < 20) {
        shades.insert(p);
        ++shaded;
      }
    }
  }
  EXPECT_GT(shaded, 100);
  EXPECT_EQ(shades.size(), 1u) << "shadows darken the ground once";
  if (!shades.empty()) {
    const auto s = *shades.begin();
    EXPECT_NEAR(s[0], ground[0] * (1.0 - 0.38), 1.5) << Describe(s);
  }
}

// Box edges (drawn by the faces' fragment shader since docs/benchmarks.md's
// third round, formerly GL lines): every edge that can show is drawn along
// its whole length in the darker edge colour, about one pixel wide, and the
// faces keep their own colour inside. Fails when edges vanish, break up or
// grow into bands.
TEST_P(RenderTest, EveryVisibleBoxEdgeIsDrawnAboutOnePixelWide) {
  Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.08));
  scene.shape.resize(1);  // the body cube alone: no other box hides an edge
  scene.modules[0].body.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.2, 0.4, 1).normalized()));
  const Camera camera = FixedCamera();
  RenderOptions options = Flat();
  options.edges = true;
  const int width = 640;
  const int height = 480;
  const Image image = renderer_->Render(scene, camera, width, height, options);
  const Image plain = renderer_->Render(scene, camera, width, height, Flat());
  const View view = ComputeView(camera, scene, width, height);
  const Color face = ModuleColor(kModuleId);
  const Color edge = {face[0] * 0.45f, face[1] * 0.45f, face[2] * 0.45f};

  int edge_pixels = 0;
  int plain_edge_pixels = 0;
  Centroid(image, edge, edge_pixels);
  Centroid(plain, edge, plain_edge_pixels);
  EXPECT_EQ(plain_edge_pixels, 0) << "no edge colour without edges";
  // The centre of the body shows the face colour, not an edge.
  const Eigen::Vector2d centre = *Project(view, scene.modules[0].body.position);
  const auto cp = image.At(static_cast<int>(centre.x()), static_cast<int>(centre.y()));
  EXPECT_TRUE(Near(cp, face)) << Describe(cp);

  // The cube's corners and which of its faces turn towards the eye.
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = scene.modules[0].body.orientation.toRotationMatrix();
  pose.translation() = scene.modules[0].body.position;
  auto corner = [&](int i) {
    return Eigen::Vector3d(pose * Eigen::Vector3d((i & 1) ? 0.05 : -0.05, (i & 2) ? 0.05 : -0.05,
                                                  (i & 4) ? 0.05 : -0.05));
  };
  auto facing = [&](int axis, int side) {
    const Eigen::Vector3d n = pose.linear().col(axis) * (side ? 1.0 : -1.0);
    return n.dot(view.eye - (pose.translation() + 0.05 * n)) > 0.0;
  };
  auto is_edge = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < width && y < height && Near(image.At(x, y), edge);
  };
  double visible_length = 0.0;
  int visible_edges = 0;
  for (int i = 0; i < 8; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      if ((i >> axis) & 1) continue;
      const int a = (axis + 1) % 3;
      const int b = (axis + 2) % 3;
      if (!facing(a, (i >> a) & 1) && !facing(b, (i >> b) & 1)) continue;  // hidden
      ++visible_edges;
      const Eigen::Vector2d p = *Project(view, corner(i));
      const Eigen::Vector2d q = *Project(view, corner(i | (1 << axis)));
      visible_length += (q - p).norm();
      // Points along the edge, away from its corners: an edge pixel within a pixel.
      for (double t = 0.1; t < 0.95; t += 0.1) {
        const Eigen::Vector2d s = p + t * (q - p);
        const int x = static_cast<int>(std::floor(s.x()));
        const int y = static_cast<int>(std::floor(s.y()));
        bool found = false;
        for (int dy = -1; dy <= 1 && !found; ++dy) {
          for (int dx = -1; dx <= 1 && !found; ++dx) found = is_edge(x + dx, y + dy);
        }
        EXPECT_TRUE(found) << "no edge pixel near " << s.transpose() << " on the edge from corner "
                           << i << " along axis " << axis;
      }
    }
  }
  EXPECT_EQ(visible_edges, 9);  // a cube seen obliquely: three faces, nine edges
  // About one pixel wide: as many edge pixels as the edges are long, give or
  // take the corners and the stair steps of slanted lines.
  EXPECT_GT(edge_pixels, 0.8 * visible_length) << "visible length " << visible_length;
  EXPECT_LT(edge_pixels, 1.6 * visible_length) << "visible length " << visible_length;
}

TEST_P(RenderTest, SeveralThreadsRenderInParallelWithTheirOwnContexts) {
  const Camera camera;
  std::vector<Scene> scenes;
  for (int i = 0; i < 4; ++i) scenes.push_back(OneModule(Eigen::Vector3d(0.1 * i, 0, 0.05)));
  std::vector<Image> sequential;
  for (const Scene& s : scenes) sequential.push_back(renderer_->Render(s, camera, 160, 120));
  std::vector<Image> parallel(scenes.size());
  std::vector<std::thread> threads;
  const Backend backend = GetParam();
  for (std::size_t i = 0; i < scenes.size(); ++i) {
    threads.emplace_back([&, i] {
      Renderer own(backend);
      for (int repeat = 0; repeat < 3; ++repeat) parallel[i] = own.Render(scenes[i], camera, 160, 120);
    });
  }
  for (std::thread& t : threads) t.join();
  for (std::size_t i = 0; i < scenes.size(); ++i) EXPECT_TRUE(parallel[i] == sequential[i]) << i;
}

TEST_P(RenderTest, BadSizesCamerasAndScenesAreRefusedNamingTheValue) {
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  auto code_of = [&](const Scene& s, const Camera& c, int w, int h) {
    try {
      renderer_->Render(s, c, w, h);
    } catch (const Error& e) {
      return std::pair<StatusCode, std::string>(e.code(), e.what());
    }
    return std::pair<StatusCode, std::string>(StatusCode::kOk, "");
  };
  EXPECT_EQ(code_of(scene, Camera{}, 0, 240),
            std::make_pair(StatusCode::kOutOfRange, std::string("frame width 0 is outside 1..4096")));
  EXPECT_EQ(code_of(scene, Camera{}, 320, 4097).first, StatusCode::kOutOfRange);
  Camera nan;
  nan.azimuth = std::nan("");
  EXPECT_EQ(code_of(scene, nan, 320, 240),
            std::make_pair(StatusCode::kInvalidArgument, std::string("camera azimuth is not finite: nan")));
  Camera degenerate = FixedCamera();
  degenerate.eye = degenerate.target;
  EXPECT_EQ(code_of(scene, degenerate, 320, 240).first, StatusCode::kInvalidArgument);
  Camera wide;
  wide.fov = 3.5;
  EXPECT_EQ(code_of(scene, wide, 320, 240).first, StatusCode::kOutOfRange);
  Camera far;
  far.distance = 0.0;
  EXPECT_EQ(code_of(scene, far, 320, 240).first, StatusCode::kOutOfRange);
  Scene diverged = scene;
  diverged.modules[0].body.position.x() = std::nan("");
  EXPECT_EQ(code_of(diverged, Camera{}, 320, 240).first, StatusCode::kInvalidArgument);
  Scene no_shape = scene;
  no_shape.shape.clear();
  EXPECT_EQ(code_of(no_shape, Camera{}, 320, 240).first, StatusCode::kInvalidArgument);
  // Straight above a follow target is a view, not a degenerate one.
  Camera above;
  above.elevation = 1.5707963267948966;
  EXPECT_EQ(code_of(scene, above, 32, 24).first, StatusCode::kOk);
}

TEST_P(RenderTest, OneRendererDrawsTheSameFrameFromThreadAfterThread) {
  // A daemon's renderers are shared by its threads (host/frames.cc): a
  // context bound on one thread must be usable from the next (EGL refuses a
  // context still current elsewhere; issue 17).
  const Scene scene = OneModule(Eigen::Vector3d(0, 0, 0.05));
  const Camera camera = FixedCamera();
  const Image first = renderer_->Render(scene, camera, 48, 32);
  for (int i = 0; i < 3; ++i) {
    std::optional<Image> other;
    std::string error;
    std::thread([&] {
      try {
        other = renderer_->Render(scene, camera, 48, 32);
      } catch (const Error& e) {
        error = e.what();
      }
    }).join();
    ASSERT_TRUE(other) << "thread " << i << ": " << error;
    EXPECT_EQ(other->rgba, first.rgba) << "thread " << i;
  }
  EXPECT_EQ(renderer_->Render(scene, camera, 48, 32).rgba, first.rgba);  // and back here
}

INSTANTIATE_TEST_SUITE_P(Backends, RenderTest, ::testing::Values(Backend::kOsMesa, Backend::kEgl),
                         [](const auto& info) { return std::string(BackendName(info.param)); });

TEST(RendererChoiceTest, NoBackendIsUnavailableNamingWhy) {
  ::setenv("YAMOR_RENDER_BACKEND", "none", 1);
  try {
    Renderer renderer;
    ADD_FAILURE() << "a renderer was created";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
    EXPECT_NE(std::string(e.what()).find("no renderer"), std::string::npos) << e.what();
  }
  ::setenv("YAMOR_RENDER_BACKEND", "vulkan", 1);
  try {
    Renderer renderer;
    ADD_FAILURE() << "a renderer was created";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), StatusCode::kUnavailable);
  }
  ::unsetenv("YAMOR_RENDER_BACKEND");
}

TEST(RendererChoiceTest, AutoPrefersOsMesaAndTheThreadRendererIsReused) {
  try {
    Renderer& a = ThreadRenderer();
    Renderer& b = ThreadRenderer();
    EXPECT_EQ(&a, &b);
    EXPECT_FALSE(a.description().empty());
    Renderer* other = nullptr;
    std::thread([&] { other = &ThreadRenderer(); }).join();
    EXPECT_NE(other, &a);
  } catch (const Error& e) {
    GTEST_SKIP() << "no renderer here: " << e.what();
  }
}

}  // namespace
}  // namespace yamor::render
