#include "physics/render/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <string>

#include <fmt/format.h>

#include "common/log.h"
#include "common/status.h"
#include "physics/render/gl_context.h"

namespace yamor::render {
namespace {

using internal::GlFunctions;

constexpr Color kGridFineColor = {0.71f, 0.69f, 0.63f};
constexpr Color kGridCoarseColor = {0.58f, 0.56f, 0.51f};
constexpr Color kLedColor = {1.0f, 0.08f, 0.05f};
constexpr Color kLegendColor = {0.16f, 0.16f, 0.18f};
constexpr Color kTextColor = {1.0f, 1.0f, 1.0f};
constexpr float kShadowAlpha = 0.38f;
constexpr double kFineGridSpacing = 0.1;    // [m]
constexpr double kFineGridExtent = 3.0;     // half-width of the 10 cm grid [m]
constexpr double kCoarseGridExtent = 40.0;  // half-width of the 1 m grid [m]
constexpr double kGroundExtent = 150.0;     // half-width of the ground quad [m]
constexpr double kLedSize = 0.008;          // [m]

Color Scale(const Color& c, float k) { return {c[0] * k, c[1] * k, c[2] * k}; }
Color Mix(const Color& a, const Color& b, float t) {
  return {a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t};
}

// ---- a 3x5 pixel font for ids and the time ---------------------------------------

// Rows top to bottom, 3 bits each (bit 2 = left column).
struct Glyph {
  char c;
  std::array<uint8_t, 5> rows;
};
constexpr Glyph kFont[] = {
    {'0', {7, 5, 5, 5, 7}}, {'1', {2, 6, 2, 2, 7}}, {'2', {7, 1, 7, 4, 7}},
    {'3', {7, 1, 7, 1, 7}}, {'4', {5, 5, 7, 1, 1}}, {'5', {7, 4, 7, 1, 7}},
    {'6', {7, 4, 7, 5, 7}}, {'7', {7, 1, 1, 1, 1}}, {'8', {7, 5, 7, 5, 7}},
    {'9', {7, 5, 7, 1, 7}}, {'.', {0, 0, 0, 0, 2}}, {'s', {3, 4, 2, 1, 6}},
    {'t', {2, 7, 2, 2, 3}}, {'=', {0, 7, 0, 7, 0}}, {'-', {0, 0, 7, 0, 0}},
    {' ', {0, 0, 0, 0, 0}},
};

const Glyph* FindGlyph(char c) {
  for (const Glyph& g : kFont) {
    if (g.c == c) return &g;
  }
  return nullptr;
}

// Text width in pixels at scale k (3 columns + 1 space per character).
int TextWidth(std::string_view text, int k) {
  return text.empty() ? 0 : static_cast<int>(text.size()) * 4 * k - k;
}

// ---- drawing helpers -----------------------------------------------------------

class Painter {
 public:
  Painter(const GlFunctions& gl, const View& view) : gl_(gl), view_(view) {}

  void SetColor(const Color& c) { gl_.Color3f(c[0], c[1], c[2]); }

  // The 8 corners of a box (local centre/size) placed at `pose`.
  static std::array<Eigen::Vector3d, 8> Corners(const Eigen::Isometry3d& pose,
                                                const Eigen::Vector3d& center,
                                                const Eigen::Vector3d& size) {
    std::array<Eigen::Vector3d, 8> corners;
    for (int i = 0; i < 8; ++i) {
      const Eigen::Vector3d sign((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.5 : -0.5, (i & 4) ? 0.5 : -0.5);
      corners[i] = pose * (center + size.cwiseProduct(sign));
    }
    return corners;
  }

  // Faces as corner indices (counter-clockwise seen from outside) and their
  // outward normals in the box frame.
  static constexpr std::array<std::array<int, 4>, 6> kFaces = {{
      {0, 2, 6, 4}, {1, 5, 7, 3},  // -x, +x
      {0, 4, 5, 1}, {2, 3, 7, 6},  // -y, +y
      {0, 1, 3, 2}, {4, 6, 7, 5},  // -z, +z
  }};

  void Box(const Eigen::Isometry3d& pose, const Eigen::Vector3d& center,
           const Eigen::Vector3d& size) {
    const auto corners = Corners(pose, center, size);
    const Eigen::Matrix3d r = pose.linear();
    gl_.Begin(GL_QUADS);
    for (int f = 0; f < 6; ++f) {
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      n[f / 2] = (f % 2 == 0) ? -1.0 : 1.0;
      const Eigen::Vector3d wn = r * n;
      gl_.Normal3d(wn.x(), wn.y(), wn.z());
      for (int i : kFaces[f]) gl_.Vertex3d(corners[i].x(), corners[i].y(), corners[i].z());
    }
    gl_.End();
  }

  void BoxEdges(const Eigen::Isometry3d& pose, const Eigen::Vector3d& center,
                const Eigen::Vector3d& size) {
    const auto corners = Corners(pose, center, size);
    gl_.Begin(GL_LINES);
    for (int i = 0; i < 8; ++i) {
      for (int bit : {1, 2, 4}) {
        if ((i & bit) != 0) continue;
        const Eigen::Vector3d& a = corners[i];
        const Eigen::Vector3d& b = corners[i | bit];
        gl_.Vertex3d(a.x(), a.y(), a.z());
        gl_.Vertex3d(b.x(), b.y(), b.z());
      }
    }
    gl_.End();
  }

  // The box's shadow on the plane z = 0, cast along `light` (towards the light).
  void BoxShadow(const Eigen::Isometry3d& pose, const Eigen::Vector3d& center,
                 const Eigen::Vector3d& size, const Eigen::Vector3d& light) {
    auto corners = Corners(pose, center, size);
    for (Eigen::Vector3d& c : corners) {
      const double h = std::max(0.0, c.z());
      c = Eigen::Vector3d(c.x() - h * light.x() / light.z(), c.y() - h * light.y() / light.z(), 0.0);
    }
    gl_.Begin(GL_QUADS);
    for (const auto& face : kFaces) {
      for (int i : face) gl_.Vertex3d(corners[i].x(), corners[i].y(), 0.0);
    }
    gl_.End();
  }

  // ---- 2-D overlay (pixel coordinates, y down) ----

  void BeginOverlay() {
    Eigen::Matrix4d ortho = Eigen::Matrix4d::Identity();
    ortho(0, 0) = 2.0 / view_.width;
    ortho(0, 3) = -1.0;
    ortho(1, 1) = -2.0 / view_.height;
    ortho(1, 3) = 1.0;
    gl_.MatrixMode(GL_PROJECTION);
    gl_.LoadMatrixd(ortho.data());
    gl_.MatrixMode(GL_MODELVIEW);
    const Eigen::Matrix4d identity = Eigen::Matrix4d::Identity();
    gl_.LoadMatrixd(identity.data());
    gl_.Disable(GL_DEPTH_TEST);
    gl_.Disable(GL_LIGHTING);
    gl_.Disable(GL_BLEND);
  }

  // Fills pixels [x0, x1) x [y0, y1).
  void Rect(int x0, int y0, int x1, int y1) {
    gl_.Vertex2i(x0, y0);
    gl_.Vertex2i(x0, y1);
    gl_.Vertex2i(x1, y1);
    gl_.Vertex2i(x1, y0);
  }

  // `text` with its top-left corner at (x, y), pixels k x k. Each run of
  // set pixels in a glyph row is one quad (the same pixels as one quad per
  // pixel, with fewer of llvmpipe's per-primitive setups).
  void Text(std::string_view text, int x, int y, int k) {
    gl_.Begin(GL_QUADS);
    for (char c : text) {
      if (const Glyph* g = FindGlyph(c)) {
        for (int row = 0; row < 5; ++row) {
          for (int col = 0; col < 3;) {
            if (((g->rows[row] >> (2 - col)) & 1) == 0) {
              ++col;
              continue;
            }
            int end = col + 1;
            while (end < 3 && ((g->rows[row] >> (2 - end)) & 1)) ++end;
            Rect(x + col * k, y + row * k, x + end * k, y + (row + 1) * k);
            col = end;
          }
        }
      }
      x += 4 * k;
    }
    gl_.End();
  }

 private:
  const GlFunctions& gl_;
  const View& view_;
};

Eigen::Isometry3d ToIsometry(const Pose& pose) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = pose.orientation.normalized().toRotationMatrix();
  t.translation() = pose.position;
  return t;
}

// Direction towards the key light: from above, a little from -x/-y of the
// true vertical, so shadows fall behind the modules in the default view.
Eigen::Vector3d LightDirection(const Scene& scene) {
  const Eigen::Vector3d up = scene.Up();
  Eigen::Vector3d e1 = Eigen::Vector3d::UnitX() - up.x() * up;
  e1.normalize();
  const Eigen::Vector3d e2 = up.cross(e1);
  return (up - 0.3 * e1 - 0.45 * e2).normalized();
}

Color BodyColor(const SceneModule& m) {
  const Color base = ModuleColor(m.id);
  return m.defective ? Mix(base, Color{0.35f, 0.35f, 0.35f}, 0.6f) : base;
}

Color HandleColor(const SceneModule& m) {
  return Mix(BodyColor(m), Color{0.92f, 0.92f, 0.92f}, 0.45f);
}

Backend ChooseAuto() {
  const char* env = std::getenv("YAMOR_RENDER_BACKEND");
  const std::string name = env ? env : "";
  if (name.empty() || name == "auto") return Backend::kAuto;
  if (name == "osmesa") return Backend::kOsMesa;
  if (name == "egl") return Backend::kEgl;
  if (name == "none") {
    throw Error(StatusCode::kUnavailable,
                "no renderer: YAMOR_RENDER_BACKEND=none (acting as a machine without one)");
  }
  throw Error(StatusCode::kUnavailable, "no renderer: YAMOR_RENDER_BACKEND=\"" + name +
                                            "\" is not auto, osmesa, egl or none");
}

}  // namespace

void ValidateFrameSize(int width, int height) {
  if (width < 1 || width > kMaxFrameSize) {
    throw Error(StatusCode::kOutOfRange,
                fmt::format("frame width {} is outside 1..{}", width, kMaxFrameSize));
  }
  if (height < 1 || height > kMaxFrameSize) {
    throw Error(StatusCode::kOutOfRange,
                fmt::format("frame height {} is outside 1..{}", height, kMaxFrameSize));
  }
}

std::string_view BackendName(Backend backend) {
  switch (backend) {
    case Backend::kAuto: return "auto";
    case Backend::kOsMesa: return "osmesa";
    case Backend::kEgl: return "egl";
  }
  return "unknown";
}

Renderer::Renderer(Backend backend) : backend_(backend) {
  if (backend_ == Backend::kAuto) backend_ = ChooseAuto();
  if (backend_ == Backend::kOsMesa) {
    context_ = internal::CreateOsMesaContext();
  } else if (backend_ == Backend::kEgl) {
    context_ = internal::CreateEglContext();
  } else {
    std::string osmesa_error;
    try {
      context_ = internal::CreateOsMesaContext();
      backend_ = Backend::kOsMesa;
    } catch (const Error& e) {
      osmesa_error = e.what();
    }
    if (!context_) {
      try {
        context_ = internal::CreateEglContext();
        backend_ = Backend::kEgl;
      } catch (const Error& e) {
        throw Error(StatusCode::kUnavailable,
                    "no renderer: " + osmesa_error + "; EGL: " + e.what() +
                        " (install libosmesa6, or libegl1 with libegl-mesa0 and "
                        "libgl1-mesa-dri: `make deps`)");
      }
    }
  }
  Log().debug("renderer: {}", context_->description());
}

Renderer::~Renderer() = default;

const std::string& Renderer::description() const { return context_->description(); }

Image Renderer::Render(const Scene& scene, const Camera& camera, int width, int height,
                       const RenderOptions& options) {
  ValidateFrameSize(width, height);
  ValidateScene(scene);
  const View view = ComputeView(camera, scene, width, height);
  context_->MakeCurrent(width, height);
  // Unbound again at the end, so the next frame may be drawn by another
  // thread (a daemon's renderers are shared by its gRPC threads).
  struct ReleaseAtEnd {
    internal::GlContext& context;
    ~ReleaseAtEnd() { context.Release(); }
  } release{*context_};
  const GlFunctions& gl = context_->gl();
  Painter paint(gl, view);
  const Eigen::Vector3d light = LightDirection(scene);

  gl.Viewport(0, 0, width, height);
  gl.ClearColor(kSkyColor[0], kSkyColor[1], kSkyColor[2], 1.0f);
  gl.ClearDepth(1.0);
  gl.ClearStencil(0);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  gl.ShadeModel(GL_FLAT);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_DITHER);
  gl.MatrixMode(GL_PROJECTION);
  gl.LoadMatrixd(view.projection.data());
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadMatrixd(view.view.data());

  // The ground and everything on it, in drawing order without depth test:
  // the objects drawn after it are never hidden by it.
  gl.Disable(GL_DEPTH_TEST);
  gl.DepthMask(GL_FALSE);
  gl.Disable(GL_LIGHTING);
  const double cx = std::round(view.target.x() / kFineGridSpacing) * kFineGridSpacing;
  const double cy = std::round(view.target.y() / kFineGridSpacing) * kFineGridSpacing;
  paint.SetColor(kGroundColor);
  gl.Begin(GL_QUADS);
  gl.Vertex3d(cx - kGroundExtent, cy - kGroundExtent, 0.0);
  gl.Vertex3d(cx + kGroundExtent, cy - kGroundExtent, 0.0);
  gl.Vertex3d(cx + kGroundExtent, cy + kGroundExtent, 0.0);
  gl.Vertex3d(cx - kGroundExtent, cy + kGroundExtent, 0.0);
  gl.End();
  if (options.grid) {
    gl.LineWidth(1.0f);
    auto lines = [&](double spacing, double extent, const Color& color) {
      const double ox = std::round(cx / spacing) * spacing;
      const double oy = std::round(cy / spacing) * spacing;
      const int n = static_cast<int>(std::round(extent / spacing));
      paint.SetColor(color);
      gl.Begin(GL_LINES);
      for (int i = -n; i <= n; ++i) {
        gl.Vertex3d(ox + i * spacing, oy - extent, 0.0);
        gl.Vertex3d(ox + i * spacing, oy + extent, 0.0);
        gl.Vertex3d(ox - extent, oy + i * spacing, 0.0);
        gl.Vertex3d(ox + extent, oy + i * spacing, 0.0);
      }
      gl.End();
    };
    lines(kFineGridSpacing, kFineGridExtent, kGridFineColor);
    lines(1.0, kCoarseGridExtent, kGridCoarseColor);
  }
  if (options.shadows && light.z() > 1e-3) {
    // Each pixel darkened once however many shadow faces cover it.
    gl.Enable(GL_STENCIL_TEST);
    gl.StencilFunc(GL_EQUAL, 0, 0xff);
    gl.StencilOp(GL_KEEP, GL_KEEP, GL_INCR);
    gl.Enable(GL_BLEND);
    gl.BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
    gl.Color4f(0.0f, 0.0f, 0.0f, kShadowAlpha);
    for (const SceneModule& m : scene.modules) {
      const Eigen::Isometry3d body = ToIsometry(m.body);
      const Eigen::Isometry3d handle = ToIsometry(m.handle);
      for (const ShapeBox& box : scene.shape) {
        paint.BoxShadow(box.part == ShapePart::kBody ? body : handle, box.center, box.size, light);
      }
    }
    for (const StaticBox& box : scene.boxes) {
      paint.BoxShadow(ToIsometry(box.pose), Eigen::Vector3d::Zero(), box.size, light);
    }
    gl.Disable(GL_BLEND);
    gl.Disable(GL_STENCIL_TEST);
  }

  // Solid objects.
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LEQUAL);
  gl.DepthMask(GL_TRUE);
  if (options.lighting) {
    const GLfloat ambient[] = {0.38f, 0.38f, 0.38f, 1.0f};
    const GLfloat key_position[] = {static_cast<GLfloat>(light.x()), static_cast<GLfloat>(light.y()),
                                    static_cast<GLfloat>(light.z()), 0.0f};
    const GLfloat key_diffuse[] = {0.62f, 0.62f, 0.60f, 1.0f};
    const GLfloat fill_position[] = {static_cast<GLfloat>(-light.x()),
                                     static_cast<GLfloat>(-light.y()), 0.35f, 0.0f};
    const GLfloat fill_diffuse[] = {0.22f, 0.22f, 0.25f, 1.0f};
    const GLfloat black[] = {0.0f, 0.0f, 0.0f, 1.0f};
    gl.LightModelfv(GL_LIGHT_MODEL_AMBIENT, ambient);
    gl.Lightfv(GL_LIGHT0, GL_POSITION, key_position);  // world frame: the view is loaded
    gl.Lightfv(GL_LIGHT0, GL_DIFFUSE, key_diffuse);
    gl.Lightfv(GL_LIGHT0, GL_AMBIENT, black);
    gl.Lightfv(GL_LIGHT0, GL_SPECULAR, black);
    gl.Lightfv(GL_LIGHT1, GL_POSITION, fill_position);
    gl.Lightfv(GL_LIGHT1, GL_DIFFUSE, fill_diffuse);
    gl.Lightfv(GL_LIGHT1, GL_AMBIENT, black);
    gl.Lightfv(GL_LIGHT1, GL_SPECULAR, black);
    gl.Materialfv(GL_FRONT_AND_BACK, GL_SPECULAR, black);
    gl.Enable(GL_LIGHT0);
    gl.Enable(GL_LIGHT1);
    gl.ColorMaterial(GL_FRONT_AND_BACK, GL_AMBIENT_AND_DIFFUSE);
    gl.Enable(GL_COLOR_MATERIAL);
  }
  auto faces = [&](auto&& draw_all) {
    if (options.lighting) gl.Enable(GL_LIGHTING);
    if (options.edges) {
      gl.Enable(GL_POLYGON_OFFSET_FILL);
      gl.PolygonOffset(1.0f, 1.0f);
    }
    draw_all(/*edges=*/false);
    gl.Disable(GL_POLYGON_OFFSET_FILL);
    gl.Disable(GL_LIGHTING);
    if (options.edges) draw_all(/*edges=*/true);
  };
  faces([&](bool edges) {
    for (const StaticBox& box : scene.boxes) {
      paint.SetColor(edges ? Scale(kStaticBoxColor, 0.55f) : kStaticBoxColor);
      const Eigen::Isometry3d pose = ToIsometry(box.pose);
      if (edges) {
        paint.BoxEdges(pose, Eigen::Vector3d::Zero(), box.size);
      } else {
        paint.Box(pose, Eigen::Vector3d::Zero(), box.size);
      }
    }
    for (const SceneModule& m : scene.modules) {
      const Eigen::Isometry3d body = ToIsometry(m.body);
      const Eigen::Isometry3d handle = ToIsometry(m.handle);
      for (const ShapeBox& box : scene.shape) {
        const bool is_body = box.part == ShapePart::kBody;
        const Color color = is_body ? BodyColor(m) : HandleColor(m);
        paint.SetColor(edges ? Scale(color, 0.45f) : color);
        if (edges) {
          paint.BoxEdges(is_body ? body : handle, box.center, box.size);
        } else {
          paint.Box(is_body ? body : handle, box.center, box.size);
        }
      }
    }
  });
  // The LED glows: unlit.
  if (const SceneModule* central = scene.Central()) {
    paint.SetColor(kLedColor);
    paint.Box(ToIsometry(central->body), scene.led,
              Eigen::Vector3d(kLedSize, kLedSize, kLedSize * 0.75));
  }

  // Overlay: ids next to the modules, then the legend strip.
  const int k = std::max(1, height / 240);
  paint.BeginOverlay();
  if (options.labels) {
    for (const SceneModule& m : scene.modules) {
      const std::optional<Eigen::Vector2d> p = Project(view, m.body.position);
      if (!p || !p->allFinite()) continue;
      const std::string text = std::to_string(m.id);
      const int w = TextWidth(text, k) + 2 * k;
      const int h = 7 * k;
      // Up and right of the body's centre, so the centre itself stays visible.
      const int x = static_cast<int>(std::floor(p->x())) + 3 * k;
      const int y = static_cast<int>(std::floor(p->y())) - 3 * k - h;
      if (x >= width || y >= height || x + w <= 0 || y + h <= 0) continue;
      paint.SetColor(Scale(BodyColor(m), 0.35f));
      gl.Begin(GL_QUADS);
      paint.Rect(x, y, x + w, y + h);
      gl.End();
      paint.SetColor(kTextColor);
      paint.Text(text, x + k, y + k, k);
    }
  }
  if (options.legend && !scene.modules.empty()) {
    const std::string time = fmt::format("t={:.2f}s", scene.time);
    const int row_height = 7 * k;
    const int time_width = TextWidth(time, k) + 4 * k;
    // Lay the entries out in rows (the first row leaves room for the time).
    struct Entry {
      int x, row;
    };
    std::vector<Entry> entries;
    int x = 2 * k;
    int row = 0;
    for (const SceneModule& m : scene.modules) {
      const int w = 5 * k + k + TextWidth(std::to_string(m.id), k) + 3 * k;
      const int limit = width - (row == 0 ? time_width : 0);
      if (x + w > limit && x > 2 * k) {
        ++row;
        x = 2 * k;
      }
      entries.push_back({x, row});
      x += w;
    }
    const int rows = entries.empty() ? 1 : entries.back().row + 1;
    const int top = height - rows * row_height - k;
    paint.SetColor(kLegendColor);
    gl.Begin(GL_QUADS);
    paint.Rect(0, top, width, height);
    gl.End();
    for (std::size_t i = 0; i < scene.modules.size(); ++i) {
      const SceneModule& m = scene.modules[i];
      const int ex = entries[i].x;
      const int ey = top + k + entries[i].row * row_height;
      paint.SetColor(BodyColor(m));
      gl.Begin(GL_QUADS);
      paint.Rect(ex, ey, ex + 5 * k, ey + 5 * k);
      gl.End();
      paint.SetColor(m.central ? kLedColor : kTextColor);
      paint.Text(std::to_string(m.id), ex + 6 * k, ey, k);
    }
    paint.SetColor(kTextColor);
    paint.Text(time, width - time_width + 2 * k, top + k, k);
  }

  Image image;
  image.width = width;
  image.height = height;
  context_->ReadPixels(width, height, image.rgba);
  if (const GLenum error = gl.GetError(); error != GL_NO_ERROR) {
    throw Error(StatusCode::kInternal, fmt::format("OpenGL error 0x{:04x} while rendering", error));
  }
  // Frames are opaque (blending leaves partial alpha behind).
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) image.rgba[i] = 255;
  return image;
}

Renderer& ThreadRenderer() {
  thread_local std::unique_ptr<Renderer> renderer;
  if (!renderer) renderer = std::make_unique<Renderer>();
  return *renderer;
}

}  // namespace yamor::render
