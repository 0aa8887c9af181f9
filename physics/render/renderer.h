// The headless renderer: draws a Scene through a Camera into an RGBA image
// with software OpenGL (OSMesa, or EGL's surfaceless platform where OSMesa is
// gone), without a display or a GPU. DESIGN.md, "Rendering".
//
// A frame shows every module's body and handle boxes in the module's colour
// (ModuleColor) with darker edges, the central module's LED, the ground with
// a 10 cm and 1 m grid (each where its lines are kMinGridSpacingPx apart or
// more), static boxes, shadows on the ground (a light from
// above, so a part touching the ground meets its shadow), the module ids
// next to the modules and a legend strip (colour, id, simulated time).
// The same scene, camera, size and options give the same bytes.
//
// Cheap enough to film every evaluation (docs/benchmarks.md, "Rendering"):
// the scene goes to OpenGL as five vertex-array batches (ground, grid,
// shadows, faces, LED) with no GL lighting (faces are flat, so each face's
// soft lighting is computed here), a view the ground fills is cleared to the
// ground colour instead of drawing the ground, the box edges are drawn by
// the faces' fragment shader rather than as lines, each box's shadow is one
// convex polygon, back faces are skipped, the ids and the legend are
// written straight into the image, and OSMesa draws into the image's own
// pixels.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "physics/render/camera.h"
#include "physics/render/image.h"
#include "physics/render/scene.h"

namespace yamor::render {

namespace internal {
class GlContext;
}  // namespace internal

/// Largest frame width or height [px].
inline constexpr int kMaxFrameSize = 4096;

/// Throws yamor::Error(OUT_OF_RANGE) naming the value unless 1 <= width,
/// height <= kMaxFrameSize.
void ValidateFrameSize(int width, int height);

/// Where the OpenGL context comes from.
enum class Backend {
  /// $YAMOR_RENDER_BACKEND when set ("osmesa", "egl", or "none" to act as a
  /// machine without a renderer), else OSMesa, else EGL surfaceless.
  kAuto,
  kOsMesa,  ///< libOSMesa.so.8 (Mesa < 25.1).
  kEgl,     ///< libEGL.so.1, EGL_PLATFORM_SURFACELESS_MESA.
};

/// "auto", "osmesa" or "egl".
std::string_view BackendName(Backend backend);

/// What to draw besides the bodies (tests switch parts off to check exact
/// colours). Thread-safety: plain value.
struct RenderOptions {
  bool lighting = true;  ///< Shade faces by two lights; off: flat module colours.
  bool edges = true;     ///< Darker box edges.
  bool grid = true;      ///< Ground grid.
  bool shadows = true;   ///< Shadows on the ground.
  bool labels = true;    ///< Module ids next to the modules.
  bool legend = true;    ///< Bottom strip: colour and id of every module, and the time.
};

/// Colour of the ground (without grid and shadows), RGB 0..1.
inline constexpr Color kGroundColor = {0.78f, 0.76f, 0.70f};
/// Colour of the 10 cm grid lines, RGB 0..1.
inline constexpr Color kGridFineColor = {0.71f, 0.69f, 0.63f};
/// Colour of the 1 m grid lines, RGB 0..1.
inline constexpr Color kGridCoarseColor = {0.58f, 0.56f, 0.51f};
/// Grid lines are drawn only where neighbouring lines of their grid land at
/// least this many pixels apart in the image [px]: closer ones merge into a
/// grey band that costs as much to draw as a visible grid (the 10 cm grid
/// shows around the robot, the 1 m grid farther out; docs/benchmarks.md).
inline constexpr double kMinGridSpacingPx = 4.0;
/// Colour of a static box (a table, a platform) without lighting, RGB 0..1.
inline constexpr Color kStaticBoxColor = {0.62f, 0.58f, 0.52f};
/// Colour of the background above the horizon, RGB 0..1.
inline constexpr Color kSkyColor = {0.86f, 0.90f, 0.95f};

/// Draws scenes. Owns one OpenGL context.
///
/// Thread-safety: not thread-safe. Render() makes the context current on the
/// calling thread, so a Renderer may move between threads but one thread at
/// a time may use it; renderers on different threads run in parallel (one
/// context per thread: ThreadRenderer()).
class Renderer {
 public:
  /// A renderer on `backend`; throws yamor::Error(UNAVAILABLE) naming what is
  /// missing ("no renderer: cannot load libOSMesa.so.8: ...; EGL: ...").
  explicit Renderer(Backend backend = Backend::kAuto);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  /// kOsMesa or kEgl: the backend in use.
  Backend backend() const { return backend_; }
  /// The library, GL renderer and version, e.g. "OSMesa: llvmpipe (...), 4.5 ...".
  const std::string& description() const;

  /// Draws `scene` seen by `camera` into a `width` x `height` image.
  /// Throws yamor::Error: OUT_OF_RANGE for a size outside 1..kMaxFrameSize,
  /// the camera's and the scene's validation errors (ValidateCamera,
  /// ValidateScene), INTERNAL when OpenGL fails.
  Image Render(const Scene& scene, const Camera& camera, int width, int height,
               const RenderOptions& options = {});
  /// As Render, into `image`, reusing its memory: for frame after frame of
  /// one size (a video), which then touches no fresh pages. On an error
  /// `image` holds no valid frame.
  void RenderInto(const Scene& scene, const Camera& camera, int width, int height,
                  const RenderOptions& options, Image& image);

 private:
  Backend backend_;
  std::unique_ptr<internal::GlContext> context_;
  // The GLSL program that draws faces with their edges (0: not built yet;
  // built at the first frame with edges, owned by context_).
  unsigned face_program_ = 0;
};

/// The calling thread's renderer (Backend::kAuto), created on first use and
/// destroyed when the thread ends: one GL context per thread. Throws
/// yamor::Error(UNAVAILABLE) when no backend works on this machine.
Renderer& ThreadRenderer();

}  // namespace yamor::render
