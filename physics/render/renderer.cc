#include "physics/render/renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common/log.h"
#include "common/status.h"
#include "physics/render/gl_context.h"

namespace yamor::render {
namespace {

using internal::GlFunctions;

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

// 8-bit channel of a colour component in [0, 1], rounded to nearest.
uint8_t Channel(float c) {
  return static_cast<uint8_t>(std::lround(std::clamp(c, 0.0f, 1.0f) * 255.0f));
}

// One vertex of a batch: position and colour, interleaved as the vertex and
// colour arrays read them.
struct Vertex {
  GLfloat xyz[3];
  GLubyte rgba[4];
};
static_assert(sizeof(Vertex) == 16);

// Vertices drawn by one glDrawArrays: the scene goes to Mesa as a handful of
// batches (ground, grid, shadows, faces, LED) instead of one
// glBegin/glEnd per box, so Mesa's per-primitive state and vertex handling
// runs a few times a frame rather than hundreds.
class Batch {
 public:
  void Add(const Eigen::Vector3d& p, const std::array<GLubyte, 4>& rgba) {
    vertices_.push_back(Vertex{{static_cast<GLfloat>(p.x()), static_cast<GLfloat>(p.y()),
                                static_cast<GLfloat>(p.z())},
                               {rgba[0], rgba[1], rgba[2], rgba[3]}});
  }
  // A quad (corners in order) as two triangles.
  void Quad(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
            const Eigen::Vector3d& d, const std::array<GLubyte, 4>& rgba) {
    for (const Eigen::Vector3d* p : {&a, &b, &c, &a, &c, &d}) Add(*p, rgba);
  }
  // A convex polygon (corners in order, at least 3) as a fan of indexed
  // triangles: each corner is shaded once, not once per triangle
  // (llvmpipe's vertex processing costs a few hundred instructions a vertex).
  void Fan(std::span<const Eigen::Vector3d> corners, const std::array<GLubyte, 4>& rgba) {
    const auto first = static_cast<GLuint>(vertices_.size());
    for (const Eigen::Vector3d& p : corners) Add(p, rgba);
    for (GLuint i = 1; i + 1 < corners.size(); ++i) {
      indices_.insert(indices_.end(), {first, first + i, first + i + 1});
    }
  }
  void Clear() {
    vertices_.clear();
    indices_.clear();
  }

  // Draws the batch as `mode` primitives (indexed when built by Fan); with
  // `colors` false every vertex takes the current colour (glColor) instead
  // of its own.
  void Draw(const GlFunctions& gl, GLenum mode, bool colors = true) const {
    if (vertices_.empty()) return;
    gl.VertexPointer(3, GL_FLOAT, sizeof(Vertex), vertices_.data()->xyz);
    if (colors) {
      gl.EnableClientState(GL_COLOR_ARRAY);
      gl.ColorPointer(4, GL_UNSIGNED_BYTE, sizeof(Vertex), vertices_.data()->rgba);
    } else {
      gl.DisableClientState(GL_COLOR_ARRAY);
    }
    if (indices_.empty()) {
      gl.DrawArrays(mode, 0, static_cast<GLsizei>(vertices_.size()));
    } else {
      gl.DrawElements(mode, static_cast<GLsizei>(indices_.size()), GL_UNSIGNED_INT,
                      indices_.data());
    }
  }

 private:
  std::vector<Vertex> vertices_;
  std::vector<GLuint> indices_;
};

std::array<GLubyte, 4> Rgba(const Color& c) {
  return {Channel(c[0]), Channel(c[1]), Channel(c[2]), 255};
}

// The 8 corners of a box (local centre/size) placed at `pose`.
std::array<Eigen::Vector3d, 8> Corners(const Eigen::Isometry3d& pose,
                                       const Eigen::Vector3d& center,
                                       const Eigen::Vector3d& size) {
  std::array<Eigen::Vector3d, 8> corners;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d sign((i & 1) ? 0.5 : -0.5, (i & 2) ? 0.5 : -0.5, (i & 4) ? 0.5 : -0.5);
    corners[i] = pose * (center + size.cwiseProduct(sign));
  }
  return corners;
}

// Faces as corner indices (clockwise seen from outside); face f's
// outward normal is axis f / 2 of the box frame, negative for even f.
constexpr std::array<std::array<int, 4>, 6> kFaces = {{
    {0, 2, 6, 4}, {1, 5, 7, 3},  // -x, +x
    {0, 4, 5, 1}, {2, 3, 7, 6},  // -y, +y
    {0, 1, 3, 2}, {4, 6, 7, 5},  // -z, +z
}};

// Soft lighting, computed per face on the CPU (faces are flat: one normal,
// one colour): an ambient term, a key light from above (`key`, unit, towards
// the light) and a dim fill light from the other side, Lambert diffuse
// terms, as OpenGL's fixed-function lighting with these lights gives. Done
// here rather than by OpenGL so the whole scene is one unlit pipeline state.
class Lighting {
 public:
  Lighting(bool on, const Eigen::Vector3d& key)
      : on_(on), key_(key), fill_(Eigen::Vector3d(-key.x(), -key.y(), 0.35).normalized()) {}

  // The colour of a face of colour `c` whose outward normal is `n` (unit).
  std::array<GLubyte, 4> Shade(const Color& c, const Eigen::Vector3d& n) const {
    if (!on_) return Rgba(c);
    const double k = std::max(0.0, n.dot(key_));
    const double f = std::max(0.0, n.dot(fill_));
    Color lit;
    for (int i = 0; i < 3; ++i) {
      lit[i] = static_cast<float>(c[i] * (kAmbient + kKeyDiffuse[i] * k + kFillDiffuse[i] * f));
    }
    return Rgba(lit);
  }

 private:
  static constexpr double kAmbient = 0.38;
  static constexpr std::array<double, 3> kKeyDiffuse = {0.62, 0.62, 0.60};
  static constexpr std::array<double, 3> kFillDiffuse = {0.22, 0.22, 0.25};
  bool on_;
  Eigen::Vector3d key_;
  Eigen::Vector3d fill_;
};

// Adds a box's six faces, each shaded by `lighting`.
void AddBox(Batch& batch, const Eigen::Isometry3d& pose, const Eigen::Vector3d& center,
            const Eigen::Vector3d& size, const Color& color, const Lighting& lighting) {
  const auto corners = Corners(pose, center, size);
  for (int f = 0; f < 6; ++f) {
    const Eigen::Vector3d n = pose.linear().col(f / 2) * ((f % 2 == 0) ? -1.0 : 1.0);
    const auto& face = kFaces[f];
    batch.Quad(corners[face[0]], corners[face[1]], corners[face[2]], corners[face[3]],
               lighting.Shade(color, n));
  }
}

// ---- faces with their edges, drawn by one GLSL program ---------------------------
//
// llvmpipe's cost is per primitive (a few thousand instructions for each line
// or triangle, whatever its size), and the ~300 GL_LINES of a frame's box
// edges cost a sixth of it. So each face draws its own edges: every vertex
// carries its distances to the face's four edges (affine on the face, so the
// interpolated value is exact), and the fragment shader paints a pixel in the
// edge colour when its distance to an edge, in pixels (the distance over the
// length of its screen-space gradient), is below the edge's half-width: one
// pixel for an edge on the box's outline (the face behind it is turned away),
// half a pixel on each side of an edge between two visible faces. Either way
// the edge is about one pixel wide, as a GL_LINE was, at any distance.

// One vertex of a face: position, the face's colour, the edge colour, the
// distances [m] to the face's four edges (0 on an edge, the side's length at
// the opposite corners) and each edge's half-width in half pixels (0: none).
struct FaceVertex {
  GLfloat xyz[3];
  GLubyte rgba[4];
  GLubyte edge_rgba[4];
  GLfloat distance[4];
  GLubyte half_width[4];
};
static_assert(sizeof(FaceVertex) == 40);

// Generic attribute locations of the face program (0 is gl_Vertex).
constexpr GLuint kEdgeColorAttribute = 1;
constexpr GLuint kEdgeDistanceAttribute = 2;
constexpr GLuint kEdgeWidthAttribute = 3;

// GLSL 1.30 (OpenGL 3.0) with the compatibility built-ins: llvmpipe offers
// OpenGL 4.5 compatibility through OSMesa and EGL alike.
constexpr const char* kFaceVertexShader = R"(#version 130
in vec4 edge_color;
in vec4 edge_distance;
in vec4 edge_width;
flat out vec4 face_rgba;
flat out vec4 edge_rgba;
flat out vec4 half_width;
out vec4 distance;
void main() {
  gl_Position = gl_ModelViewProjectionMatrix * gl_Vertex;
  face_rgba = gl_Color;
  edge_rgba = edge_color;
  half_width = edge_width;
  distance = edge_distance;
}
)";

// On an edge when distance / |gradient| < half_width / 2 pixels, compared
// squared (no square root, no division by a zero gradient).
constexpr const char* kFaceFragmentShader = R"(#version 130
flat in vec4 face_rgba;
flat in vec4 edge_rgba;
flat in vec4 half_width;
in vec4 distance;
void main() {
  vec4 gx = dFdx(distance);
  vec4 gy = dFdy(distance);
  bvec4 on = lessThan(4.0 * distance * distance, half_width * half_width * (gx * gx + gy * gy));
  gl_FragColor = any(on) ? edge_rgba : face_rgba;
}
)";

// Compiles and links the face program in the current context; throws
// yamor::Error(INTERNAL) with the compiler's log when OpenGL refuses it.
GLuint BuildFaceProgram(const GlFunctions& gl) {
  auto compile = [&](GLenum type, const char* source, const char* what) {
    const GLuint shader = gl.CreateShader(type);
    gl.ShaderSource(shader, 1, &source, nullptr);
    gl.CompileShader(shader);
    GLint ok = GL_FALSE;
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (ok != GL_TRUE) {
      std::array<char, 2048> log{};
      gl.GetShaderInfoLog(shader, static_cast<GLsizei>(log.size()), nullptr, log.data());
      gl.DeleteShader(shader);
      throw Error(StatusCode::kInternal,
                  fmt::format("OpenGL refused the face {} shader: {}", what, log.data()));
    }
    return shader;
  };
  const GLuint vertex = compile(GL_VERTEX_SHADER, kFaceVertexShader, "vertex");
  const GLuint fragment = compile(GL_FRAGMENT_SHADER, kFaceFragmentShader, "fragment");
  const GLuint program = gl.CreateProgram();
  gl.AttachShader(program, vertex);
  gl.AttachShader(program, fragment);
  gl.BindAttribLocation(program, kEdgeColorAttribute, "edge_color");
  gl.BindAttribLocation(program, kEdgeDistanceAttribute, "edge_distance");
  gl.BindAttribLocation(program, kEdgeWidthAttribute, "edge_width");
  gl.LinkProgram(program);
  gl.DeleteShader(vertex);  // freed with the program
  gl.DeleteShader(fragment);
  GLint ok = GL_FALSE;
  gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    std::array<char, 2048> log{};
    gl.GetProgramInfoLog(program, static_cast<GLsizei>(log.size()), nullptr, log.data());
    throw Error(StatusCode::kInternal,
                fmt::format("OpenGL refused to link the face program: {}", log.data()));
  }
  return program;
}

// Faces with edges, drawn as GL_TRIANGLES by the face program.
class FaceBatch {
 public:
  // Adds a box's six faces, each shaded by `lighting`, with edges of colour
  // `edge` where they can show from `eye`: an edge between two faces turned
  // away from the eye lies behind the box (a closed convex solid), one
  // between a visible face and a hidden one is on the outline (the visible
  // face draws all of its width), one between two visible faces is shared
  // (each draws half).
  void AddBox(const Eigen::Isometry3d& pose, const Eigen::Vector3d& center,
              const Eigen::Vector3d& size, const Color& color, const Color& edge,
              const Lighting& lighting, const Eigen::Vector3d& eye) {
    const auto corners = Corners(pose, center, size);
    std::array<bool, 6> facing{};
    std::array<Eigen::Vector3d, 6> normals;
    for (int f = 0; f < 6; ++f) {
      normals[f] = pose.linear().col(f / 2) * ((f % 2 == 0) ? -1.0 : 1.0);
      facing[f] = normals[f].dot(eye - corners[kFaces[f][0]]) > 0.0;
    }
    const auto edge_rgba = Rgba(edge);
    for (int f = 0; f < 6; ++f) {
      // A face turned away from the eye would only be culled by OpenGL after
      // its vertices were shaded: it is not sent at all.
      if (!facing[f]) continue;
      const auto& face = kFaces[f];
      std::array<GLubyte, 4> half_width{};
      std::array<float, 4> side{};  // side k from face[k] to face[k + 1]
      for (int k = 0; k < 4; ++k) {
        const int a = face[k];
        const int b = face[(k + 1) % 4];
        const int edge_axis = (a ^ b) == 1 ? 0 : (a ^ b) == 2 ? 1 : 2;
        const int other_axis = 3 - f / 2 - edge_axis;
        const int neighbour = 2 * other_axis + ((a >> other_axis) & 1);
        half_width[k] = facing[neighbour] ? 1 : 2;
        side[k] = static_cast<float>((corners[b] - corners[a]).norm());
      }
      const auto rgba = lighting.Shade(color, normals[f]);
      // Corner j lies on sides j - 1 and j; its distance to side k is the
      // length of the side next to k otherwise.
      auto add = [&](int j) {
        FaceVertex v{};
        const Eigen::Vector3d& p = corners[face[j]];
        v.xyz[0] = static_cast<GLfloat>(p.x());
        v.xyz[1] = static_cast<GLfloat>(p.y());
        v.xyz[2] = static_cast<GLfloat>(p.z());
        std::memcpy(v.rgba, rgba.data(), 4);
        std::memcpy(v.edge_rgba, edge_rgba.data(), 4);
        for (int k = 0; k < 4; ++k) {
          const bool on = j == k || j == (k + 1) % 4;
          v.distance[k] = on ? 0.0f : side[(k + 1) % 4];
        }
        std::memcpy(v.half_width, half_width.data(), 4);
        vertices_.push_back(v);
      };
      // Two indexed triangles: each corner shaded once.
      const auto first = static_cast<GLuint>(vertices_.size());
      for (int j = 0; j < 4; ++j) add(j);
      indices_.insert(indices_.end(),
                      {first, first + 1, first + 2, first, first + 2, first + 3});
    }
  }

  // Draws the faces with `program` (current state: depth test, culling).
  void Draw(const GlFunctions& gl, GLuint program) const {
    if (vertices_.empty()) return;
    const FaceVertex* v = vertices_.data();
    gl.UseProgram(program);
    gl.VertexPointer(3, GL_FLOAT, sizeof(FaceVertex), v->xyz);
    gl.EnableClientState(GL_COLOR_ARRAY);
    gl.ColorPointer(4, GL_UNSIGNED_BYTE, sizeof(FaceVertex), v->rgba);
    gl.VertexAttribPointer(kEdgeColorAttribute, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(FaceVertex),
                           v->edge_rgba);
    gl.VertexAttribPointer(kEdgeDistanceAttribute, 4, GL_FLOAT, GL_FALSE, sizeof(FaceVertex),
                           v->distance);
    gl.VertexAttribPointer(kEdgeWidthAttribute, 4, GL_UNSIGNED_BYTE, GL_FALSE, sizeof(FaceVertex),
                           v->half_width);
    for (GLuint a : {kEdgeColorAttribute, kEdgeDistanceAttribute, kEdgeWidthAttribute}) {
      gl.EnableVertexAttribArray(a);
    }
    gl.DrawElements(GL_TRIANGLES, static_cast<GLsizei>(indices_.size()), GL_UNSIGNED_INT,
                    indices_.data());
    for (GLuint a : {kEdgeColorAttribute, kEdgeDistanceAttribute, kEdgeWidthAttribute}) {
      gl.DisableVertexAttribArray(a);
    }
    gl.UseProgram(0);
  }

 private:
  std::vector<FaceVertex> vertices_;
  std::vector<GLuint> indices_;
};

// Adds the box's shadow on the plane z = 0, cast along `light` (towards the
// light): the convex hull of its corners projected onto the ground (a box is
// convex, so its shadow is the hull of its corners' shadows), as a triangle
// fan: one polygon instead of six overlapping faces.
void AddBoxShadow(Batch& batch, const Eigen::Isometry3d& pose, const Eigen::Vector3d& center,
                  const Eigen::Vector3d& size, const Eigen::Vector3d& light) {
  const auto corners = Corners(pose, center, size);
  std::array<Eigen::Vector2d, 8> points;
  for (int i = 0; i < 8; ++i) {
    const Eigen::Vector3d& c = corners[i];
    const double h = std::max(0.0, c.z());
    points[i] = Eigen::Vector2d(c.x() - h * light.x() / light.z(),
                                c.y() - h * light.y() / light.z());
  }
  // Andrew's monotone chain: counter-clockwise hull without collinear points.
  std::sort(points.begin(), points.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
  };
  std::array<Eigen::Vector2d, 16> hull;
  int n = 0;
  for (int i = 0; i < 8; ++i) {  // lower hull
    while (n >= 2 && cross(hull[n - 2], hull[n - 1], points[i]) <= 0) --n;
    hull[n++] = points[i];
  }
  for (int i = 6, lower = n + 1; i >= 0; --i) {  // upper hull
    while (n >= lower && cross(hull[n - 2], hull[n - 1], points[i]) <= 0) --n;
    hull[n++] = points[i];
  }
  --n;  // the last point repeats the first
  if (n < 3) return;  // a box seen edge-on by the light casts no area
  std::array<Eigen::Vector3d, 16> polygon;
  for (int i = 0; i < n; ++i) polygon[i] = Eigen::Vector3d(hull[i].x(), hull[i].y(), 0.0);
  batch.Fan(std::span<const Eigen::Vector3d>(polygon.data(), static_cast<std::size_t>(n)),
            {0, 0, 0, 0});  // drawn with glColor
}

// ---- 2-D overlay, drawn straight into the image (pixel coordinates, y down) ----

// Fills pixels [x0, x1) x [y0, y1) (clipped to the image) with `color`.
void FillRect(Image& image, int x0, int y0, int x1, int y1, const Color& color) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, image.width);
  y1 = std::min(y1, image.height);
  const std::array<GLubyte, 4> rgba = Rgba(color);
  for (int y = y0; y < y1; ++y) {
    uint8_t* p = &image.rgba[(static_cast<std::size_t>(y) * image.width + x0) * 4];
    for (int x = x0; x < x1; ++x, p += 4) std::memcpy(p, rgba.data(), 4);
  }
}

// `text` with its top-left corner at (x, y), font pixels k x k.
void DrawText(Image& image, std::string_view text, int x, int y, int k, const Color& color) {
  for (char c : text) {
    if (const Glyph* g = FindGlyph(c)) {
      for (int row = 0; row < 5; ++row) {
        for (int col = 0; col < 3; ++col) {
          if (((g->rows[row] >> (2 - col)) & 1) == 0) continue;
          FillRect(image, x + col * k, y + row * k, x + (col + 1) * k, y + (row + 1) * k, color);
        }
      }
    }
    x += 4 * k;
  }
}

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

// The radius around the eye's foot point on the ground (z = 0) within which
// lines `spacing` metres apart are at least kMinGridSpacingPx apart in the
// image, or infinity when the eye is not above the ground. A ground point at
// distance D from an eye h above the ground shows a step s as at least
// f·s·h/D² pixels (f: focal length in pixels; the step along the line of
// sight, foreshortened by h/D) and a step across it as f·s/D; so lines
// within D² <= f·s·h/k are at least k pixels apart in every direction.
// Returns 0 when the lines would be closer than that everywhere.
double GridRadius(const View& view, double spacing) {
  const double h = view.eye.z();
  if (!(h > 0.0)) return std::numeric_limits<double>::infinity();
  const double focal = view.projection(1, 1) * 0.5 * view.height;
  const double d2 = focal * spacing * h / kMinGridSpacingPx;
  return d2 > h * h ? std::sqrt(d2 - h * h) : 0.0;
}

// True when the ground square (half-width kGroundExtent around (cx, cy), z
// = 0) covers the whole view: then the frame is cleared to the ground colour
// instead of to the sky's with the ground drawn over it, the same pixels
// without a full-frame polygon (llvmpipe shades every 4x4 block of a
// polygon, and the ground quad was a quarter of a frame's cost). The pixels
// whose rays meet the square form a convex region of the image (the
// projection of a convex polygon in front of the eye), so the view is
// covered when the rays through its four corners meet the square, between
// the near and far planes, with a metre to spare.
bool GroundFillsView(const View& view, double cx, double cy) {
  const Eigen::Matrix4d inverse = (view.projection * view.view).inverse();
  for (const double nx : {-1.0, 1.0}) {
    for (const double ny : {-1.0, 1.0}) {
      const Eigen::Vector4d a = inverse * Eigen::Vector4d(nx, ny, -1.0, 1.0);
      const Eigen::Vector4d b = inverse * Eigen::Vector4d(nx, ny, 1.0, 1.0);
      if (!(a.w() != 0.0 && b.w() != 0.0)) return false;
      const Eigen::Vector3d near = a.head<3>() / a.w();
      const Eigen::Vector3d far = b.head<3>() / b.w();
      if (!((near.z() > 0.0 && far.z() < 0.0) || (near.z() < 0.0 && far.z() > 0.0))) return false;
      const double t = near.z() / (near.z() - far.z());
      const Eigen::Vector3d hit = near + t * (far - near);
      const double margin = kGroundExtent - 1.0;
      if (!hit.allFinite() || std::abs(hit.x() - cx) > margin || std::abs(hit.y() - cy) > margin) {
        return false;
      }
    }
  }
  return true;
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
  Image image;
  RenderInto(scene, camera, width, height, options, image);
  return image;
}

void Renderer::RenderInto(const Scene& scene, const Camera& camera, int width, int height,
                          const RenderOptions& options, Image& image) {
  ValidateFrameSize(width, height);
  ValidateScene(scene);
  const View view = ComputeView(camera, scene, width, height);
  // `image` is the caller's, so OSMesa's target (its pixels) outlives the
  // context's binding, released below, even when drawing throws.
  image.width = width;
  image.height = height;
  context_->MakeCurrent(width, height, image.rgba);
  // Unbound again at the end, so the next frame may be drawn by another
  // thread (a daemon's renderers are shared by its gRPC threads).
  struct ReleaseAtEnd {
    internal::GlContext& context;
    ~ReleaseAtEnd() { context.Release(); }
  } release{*context_};
  const GlFunctions& gl = context_->gl();
  const Eigen::Vector3d light = LightDirection(scene);

  // The ground square's centre: the view's target on the 10 cm grid.
  const double cx = std::round(view.target.x() / kFineGridSpacing) * kFineGridSpacing;
  const double cy = std::round(view.target.y() / kFineGridSpacing) * kFineGridSpacing;
  const bool ground_fills_view = GroundFillsView(view, cx, cy);
  const std::array<GLubyte, 4> ground_rgba = Rgba(kGroundColor);

  gl.Viewport(0, 0, width, height);
  if (ground_fills_view) {
    // The same 8-bit colour as the ground polygon's.
    gl.ClearColor(ground_rgba[0] / 255.0f, ground_rgba[1] / 255.0f, ground_rgba[2] / 255.0f, 1.0f);
  } else {
    gl.ClearColor(kSkyColor[0], kSkyColor[1], kSkyColor[2], 1.0f);
  }
  gl.ClearDepth(1.0);
  gl.ClearStencil(0);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
  gl.ShadeModel(GL_FLAT);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_DITHER);
  gl.Disable(GL_LIGHTING);  // lit on the CPU (Lighting)
  gl.MatrixMode(GL_PROJECTION);
  gl.LoadMatrixd(view.projection.data());
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadMatrixd(view.view.data());
  gl.EnableClientState(GL_VERTEX_ARRAY);

  // The ground and everything on it, in drawing order without depth test:
  // the objects drawn after it are never hidden by it.
  Batch batch;
  gl.Disable(GL_DEPTH_TEST);
  gl.DepthMask(GL_FALSE);
  if (!ground_fills_view) {
    batch.Quad(Eigen::Vector3d(cx - kGroundExtent, cy - kGroundExtent, 0.0),
               Eigen::Vector3d(cx + kGroundExtent, cy - kGroundExtent, 0.0),
               Eigen::Vector3d(cx + kGroundExtent, cy + kGroundExtent, 0.0),
               Eigen::Vector3d(cx - kGroundExtent, cy + kGroundExtent, 0.0), ground_rgba);
    batch.Draw(gl, GL_TRIANGLES);
  }
  if (options.grid) {
    batch.Clear();
    gl.LineWidth(1.0f);
    // Lines every `spacing` metres within `extent` of the centre and within
    // GridRadius of the eye's foot point (farther away they would crowd into
    // a band: the 10 cm grid shows around the robot, the 1 m grid farther),
    // leaving out those on every `skip`-th line (drawn by the coarser grid).
    const double ex = view.eye.x();
    const double ey = view.eye.y();
    auto lines = [&](double spacing, double extent, int skip, const Color& color) {
      const long long jx = std::llround(cx / spacing);
      const long long jy = std::llround(cy / spacing);
      const double ox = static_cast<double>(jx) * spacing;
      const double oy = static_cast<double>(jy) * spacing;
      const int n = static_cast<int>(std::round(extent / spacing));
      const double radius = GridRadius(view, spacing);
      const auto rgba = Rgba(color);
      // The part of the line at `offset` from the eye's foot point along one
      // axis that lies within `radius`, as the span [lo, hi] along the other
      // axis (centred on `e`, clipped to the grid's square [o - extent, o + extent]).
      auto span = [&](double offset, double e, double o, double& lo, double& hi) {
        lo = o - extent;
        hi = o + extent;
        if (std::isinf(radius)) return true;
        const double w2 = radius * radius - offset * offset;
        if (w2 <= 0.0) return false;
        const double w = std::sqrt(w2);
        lo = std::max(lo, e - w);
        hi = std::min(hi, e + w);
        return lo < hi;
      };
      double lo = 0.0;
      double hi = 0.0;
      for (int i = -n; i <= n; ++i) {
        const double x = ox + i * spacing;
        if ((skip == 0 || (jx + i) % skip != 0) && span(x - ex, ey, oy, lo, hi)) {
          batch.Add(Eigen::Vector3d(x, lo, 0.0), rgba);
          batch.Add(Eigen::Vector3d(x, hi, 0.0), rgba);
        }
        const double y = oy + i * spacing;
        if ((skip == 0 || (jy + i) % skip != 0) && span(y - ey, ex, ox, lo, hi)) {
          batch.Add(Eigen::Vector3d(lo, y, 0.0), rgba);
          batch.Add(Eigen::Vector3d(hi, y, 0.0), rgba);
        }
      }
    };
    const int per_metre = static_cast<int>(std::lround(1.0 / kFineGridSpacing));
    lines(kFineGridSpacing, kFineGridExtent, per_metre, kGridFineColor);
    lines(1.0, kCoarseGridExtent, 0, kGridCoarseColor);
    batch.Draw(gl, GL_LINES);
  }
  if (options.shadows && light.z() > 1e-3) {
    batch.Clear();
    for (const SceneModule& m : scene.modules) {
      const Eigen::Isometry3d body = ToIsometry(m.body);
      const Eigen::Isometry3d handle = ToIsometry(m.handle);
      for (const ShapeBox& box : scene.shape) {
        AddBoxShadow(batch, box.part == ShapePart::kBody ? body : handle, box.center, box.size,
                     light);
      }
    }
    for (const StaticBox& box : scene.boxes) {
      AddBoxShadow(batch, ToIsometry(box.pose), Eigen::Vector3d::Zero(), box.size, light);
    }
    // Each pixel darkened once however many shadows cover it.
    gl.Enable(GL_STENCIL_TEST);
    gl.StencilFunc(GL_EQUAL, 0, 0xff);
    gl.StencilOp(GL_KEEP, GL_KEEP, GL_INCR);
    gl.Enable(GL_BLEND);
    // Alpha stays 1 (frames are opaque, with no pass over them to fix it).
    gl.BlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ZERO, GL_ONE);
    gl.Color4f(0.0f, 0.0f, 0.0f, kShadowAlpha);
    batch.Draw(gl, GL_TRIANGLES, /*colors=*/false);
    gl.Disable(GL_BLEND);
    gl.Disable(GL_STENCIL_TEST);
  }

  // Solid objects: every face in one batch, with their edges when asked for
  // (the face program), else flat faces (fixed function).
  gl.Enable(GL_DEPTH_TEST);
  gl.DepthFunc(GL_LEQUAL);
  gl.DepthMask(GL_TRUE);
  const Lighting lighting(options.lighting, light);
  batch.Clear();
  FaceBatch faces;
  for (const StaticBox& box : scene.boxes) {
    const Eigen::Isometry3d pose = ToIsometry(box.pose);
    if (options.edges) {
      faces.AddBox(pose, Eigen::Vector3d::Zero(), box.size, kStaticBoxColor,
                   Scale(kStaticBoxColor, 0.55f), lighting, view.eye);
    } else {
      AddBox(batch, pose, Eigen::Vector3d::Zero(), box.size, kStaticBoxColor, lighting);
    }
  }
  for (const SceneModule& m : scene.modules) {
    const Eigen::Isometry3d body = ToIsometry(m.body);
    const Eigen::Isometry3d handle = ToIsometry(m.handle);
    for (const ShapeBox& box : scene.shape) {
      const bool is_body = box.part == ShapePart::kBody;
      const Color color = is_body ? BodyColor(m) : HandleColor(m);
      if (options.edges) {
        faces.AddBox(is_body ? body : handle, box.center, box.size, color, Scale(color, 0.45f),
                     lighting, view.eye);
      } else {
        AddBox(batch, is_body ? body : handle, box.center, box.size, color, lighting);
      }
    }
  }
  // Boxes are closed and convex: their back faces are always hidden by their
  // front faces, so they are not rasterised at all.
  gl.Enable(GL_CULL_FACE);
  gl.CullFace(GL_BACK);
  gl.FrontFace(GL_CW);  // kFaces' winding
  if (options.edges) {
    if (face_program_ == 0) face_program_ = BuildFaceProgram(gl);
    faces.Draw(gl, face_program_);
  } else {
    batch.Draw(gl, GL_TRIANGLES);
  }
  // The LED glows: unlit.
  if (const SceneModule* central = scene.Central()) {
    batch.Clear();
    AddBox(batch, ToIsometry(central->body), scene.led,
           Eigen::Vector3d(kLedSize, kLedSize, kLedSize * 0.75), kLedColor,
           Lighting(/*on=*/false, light));
    batch.Draw(gl, GL_TRIANGLES);
  }
  gl.Disable(GL_CULL_FACE);
  gl.DisableClientState(GL_COLOR_ARRAY);
  gl.DisableClientState(GL_VERTEX_ARRAY);

  context_->ReadPixels(width, height, image.rgba);
  if (const GLenum error = gl.GetError(); error != GL_NO_ERROR) {
    throw Error(StatusCode::kInternal, fmt::format("OpenGL error 0x{:04x} while rendering", error));
  }

  // Overlay, drawn into the image (a few hundred pixels of flat colour, far
  // cheaper than OpenGL quads): ids next to the modules, then the legend strip.
  const int k = std::max(1, height / 240);
  if (options.labels) {
    for (const SceneModule& m : scene.modules) {
      const std::optional<Eigen::Vector2d> p = Project(view, m.body.position);
      if (!p || !p->allFinite()) continue;
      const std::string text = std::to_string(m.id);
      const int w = TextWidth(text, k) + 2 * k;
      const int h = 7 * k;
      // Up and right of the body's centre, so the centre itself stays visible.
      const double px = std::floor(p->x()) + 3 * k;
      const double py = std::floor(p->y()) - 3 * k - h;
      if (px >= width || py >= height || px + w <= 0 || py + h <= 0) continue;
      const int x = static_cast<int>(px);
      const int y = static_cast<int>(py);
      FillRect(image, x, y, x + w, y + h, Scale(BodyColor(m), 0.35f));
      DrawText(image, text, x + k, y + k, k, kTextColor);
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
    FillRect(image, 0, top, width, height, kLegendColor);
    for (std::size_t i = 0; i < scene.modules.size(); ++i) {
      const SceneModule& m = scene.modules[i];
      const int ex = entries[i].x;
      const int ey = top + k + entries[i].row * row_height;
      FillRect(image, ex, ey, ex + 5 * k, ey + 5 * k, BodyColor(m));
      DrawText(image, std::to_string(m.id), ex + 6 * k, ey, k, m.central ? kLedColor : kTextColor);
    }
    DrawText(image, time, width - time_width + 2 * k, top + k, k, kTextColor);
  }
}

Renderer& ThreadRenderer() {
  thread_local std::unique_ptr<Renderer> renderer;
  if (!renderer) renderer = std::make_unique<Renderer>();
  return *renderer;
}

}  // namespace yamor::render
