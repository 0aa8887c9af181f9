// The static boxes of a world in its scene: bridge::SceneOf carries them,
// the SNP scene snapshot keeps them, and the renderer draws them (pixel test).
#include "bridge/scene.h"

#include <cmath>
#include <cstdlib>
#include <memory>

#include <gtest/gtest.h>

#include "common/status.h"
#include "physics/render/renderer.h"
#include "physics/render/snapshot.h"
#include "proto/snp/scene.h"

namespace yamor::bridge {
namespace {

// One module standing on a 40 x 40 x 20 cm block, and a low step yawed by 30°
// half a metre away.
physics::Morphology OnABlock() {
  return physics::Morphology::Parse(
      "<morphology central=\"0\">\n"
      "  <module id=\"0\"/>\n"
      "  <box name=\"block\" size=\"0.4 0.4 0.2\" position=\"0 0 0.1\"/>\n"
      "  <box name=\"step\" size=\"0.3 0.2 0.05\" position=\"0 0.6 0.025\" orientation=\"0 0 30\"/>\n"
      "</morphology>\n",
      "block.xml");
}

bool Near(const std::array<uint8_t, 4>& pixel, const render::Color& c) {
  for (int i = 0; i < 3; ++i) {
    if (std::abs(pixel[i] - static_cast<int>(std::lround(c[i] * 255))) > 1) return false;
  }
  return true;
}

TEST(SceneBoxesTest, SceneOfAWorldCarriesItsStaticBoxes) {
  const physics::World world(OnABlock());
  const render::Scene scene = SceneOf(world);
  ASSERT_EQ(scene.boxes.size(), 2u);
  EXPECT_TRUE(scene.boxes[0].size.isApprox(Eigen::Vector3d(0.4, 0.4, 0.2)));
  EXPECT_TRUE(scene.boxes[0].pose.position.isApprox(Eigen::Vector3d(0, 0, 0.1)));
  EXPECT_TRUE(scene.boxes[1].pose.position.isApprox(Eigen::Vector3d(0, 0.6, 0.025)));
  const Eigen::Vector3d x_axis = scene.boxes[1].pose.orientation * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(std::atan2(x_axis.y(), x_axis.x()), M_PI / 6, 1e-9);
  render::ValidateScene(scene);
  // Through the SNP snapshot (what ReadScene carries) and back.
  const snp::SceneSnapshot snapshot =
      snp::DecodeSceneSnapshot(snp::EncodeSceneSnapshot(render::ToSnapshot(scene)));
  const render::Scene back = render::FromSnapshot(snapshot);
  ASSERT_EQ(back.boxes.size(), 2u);
  EXPECT_TRUE(back.boxes[1].pose.position.isApprox(scene.boxes[1].pose.position, 1e-6));
  EXPECT_TRUE(back.boxes[1].size.isApprox(scene.boxes[1].size, 1e-6));
  // A world without boxes has none in its scene.
  const physics::World bare(physics::Morphology::Parse(
      "<morphology central=\"0\"><module id=\"0\"/></morphology>", "bare"));
  EXPECT_TRUE(SceneOf(bare).boxes.empty());
}

TEST(SceneBoxesTest, RendererDrawsTheBoxesOfAWorld) {
  std::unique_ptr<render::Renderer> renderer;
  try {
    renderer = std::make_unique<render::Renderer>();
  } catch (const Error& e) {
    GTEST_SKIP() << "no renderer here: " << e.what();
  }
  const physics::World world(OnABlock());
  const render::Scene scene = SceneOf(world);
  render::Camera camera;
  camera.kind = render::CameraKind::kFixed;
  camera.eye = Eigen::Vector3d(1.2, -1.4, 1.0);
  camera.target = Eigen::Vector3d(0.0, 0.2, 0.1);
  const render::RenderOptions flat{.lighting = false, .edges = false, .grid = false,
                                   .shadows = false, .labels = false, .legend = false};
  const render::Image image = renderer->Render(scene, camera, 320, 240, flat);
  const render::View view = render::ComputeView(camera, scene, 320, 240);
  auto pixel = [&](const Eigen::Vector3d& point) {
    const Eigen::Vector2d p = *render::Project(view, point);
    return image.At(static_cast<int>(p.x()), static_cast<int>(p.y()));
  };
  // The block's front face below the module, and the step's top: box colour.
  EXPECT_TRUE(Near(pixel(Eigen::Vector3d(0.1, -0.2, 0.05)), render::kStaticBoxColor));
  EXPECT_TRUE(Near(pixel(Eigen::Vector3d(0.0, 0.6, 0.05)), render::kStaticBoxColor));
  // The module on top of the block in its own colour, the floor beside.
  EXPECT_TRUE(Near(pixel(world.CentralPosition()), render::ModuleColor(0)));
  EXPECT_TRUE(Near(pixel(Eigen::Vector3d(0.6, -0.4, 0.0)), render::kGroundColor));
  // Without the boxes the block's face shows the floor.
  render::Scene no_boxes = scene;
  no_boxes.boxes.clear();
  const render::Image bare = renderer->Render(no_boxes, camera, 320, 240, flat);
  const Eigen::Vector2d face = *render::Project(view, Eigen::Vector3d(0.1, -0.2, 0.05));
  EXPECT_FALSE(Near(bare.At(static_cast<int>(face.x()), static_cast<int>(face.y())),
                    render::kStaticBoxColor));
}

}  // namespace
}  // namespace yamor::bridge
