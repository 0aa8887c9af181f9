// Internal to yamor_render: an offscreen OpenGL context without a display,
// from OSMesa (libOSMesa.so.8) or EGL's surfaceless platform (libEGL.so.1),
// both loaded with dlopen at run time. Nothing links libGL: every GL entry
// point is resolved through the chosen library (OSMesaGetProcAddress or
// eglGetProcAddress), so calls can never land in another GL library (with
// libGL linked next to OSMesa they would, and frames would come out blank).
// Loading at run time also lets one binary use EGL on a machine whose Mesa
// (>= 25.1) no longer ships OSMesa, and report "no renderer" instead of
// failing to start.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <GL/gl.h>
#include <GL/glext.h>

namespace yamor::render::internal {

/// The GL functions the renderer uses (fixed-function OpenGL 1.x, framebuffer
/// objects for EGL, GLSL programs for the faces' edges), resolved from the
/// backend's library.
struct GlFunctions {
#define YAMOR_GL_FUNCTION(name) decltype(&::gl##name) name = nullptr;
#define YAMOR_GL_EXTENSION(name, type) type name = nullptr;
#include "physics/render/gl_functions.inc"
#undef YAMOR_GL_FUNCTION
#undef YAMOR_GL_EXTENSION
};

/// Which library provides the context.
enum class GlLibrary { kOsMesa, kEgl };

/// One offscreen GL context with a colour + depth + stencil target.
/// Thread-safety: not thread-safe; MakeCurrent binds it to the calling
/// thread and Release unbinds it, so one thread at a time may use it (it
/// may change threads between a Release and the next MakeCurrent).
class GlContext {
 public:
  virtual ~GlContext() = default;
  /// Makes the context current on this thread with a `width` x `height`
  /// target (re-allocated when the size changed) whose pixels ReadPixels
  /// puts into `rgba` (OSMesa draws into `rgba` itself: it must stay where it
  /// is until ReadPixels). Throws INTERNAL on failure.
  virtual void MakeCurrent(int width, int height, std::vector<uint8_t>& rgba) = 0;
  /// Finishes drawing and leaves the frame in `rgba` (the vector given to
  /// MakeCurrent), width x height x 4 bytes, rows from top to bottom.
  virtual void ReadPixels(int width, int height, std::vector<uint8_t>& rgba) = 0;
  /// Unbinds the context from the calling thread so another thread may make
  /// it current (EGL refuses a context current on another thread).
  virtual void Release() {}
  /// The GL functions (valid while the context is current).
  const GlFunctions& gl() const { return gl_; }
  /// The library.
  virtual GlLibrary library() const = 0;
  /// "OSMesa: llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Compatibility Profile) Mesa 22.3.6".
  const std::string& description() const { return description_; }

 protected:
  GlFunctions gl_;
  std::string description_;
};

/// A new OSMesa context; throws UNAVAILABLE naming why (library missing,
/// context refused).
std::unique_ptr<GlContext> CreateOsMesaContext();
/// A new EGL surfaceless context; throws UNAVAILABLE naming why.
std::unique_ptr<GlContext> CreateEglContext();

}  // namespace yamor::render::internal
