#include "physics/render/gl_context.h"

#include <dlfcn.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/osmesa.h>

#include <array>
#include <cstring>
#include <mutex>
#include <string>

#include "common/status.h"

namespace yamor::render::internal {
namespace {

using ProcResolver = void* (*)(const char* name, void* library);

[[noreturn]] void Unavailable(const std::string& what) {
  throw Error(StatusCode::kUnavailable, what);
}

std::string DlError() {
  const char* e = dlerror();
  return e ? e : "unknown dlopen error";
}

// Fills every entry of `gl`; throws UNAVAILABLE naming a missing function.
void ResolveFunctions(GlFunctions& gl, ProcResolver resolve, void* library,
                      const std::string& library_name) {
  auto load = [&](auto& slot, const char* name) {
    void* p = resolve(name, library);
    if (p == nullptr) Unavailable(library_name + " has no " + name);
    slot = reinterpret_cast<std::remove_reference_t<decltype(slot)>>(p);
  };
#define YAMOR_GL_FUNCTION(name) load(gl.name, "gl" #name);
#define YAMOR_GL_EXTENSION(name, type) load(gl.name, "gl" #name);
#include "physics/render/gl_functions.inc"
#undef YAMOR_GL_FUNCTION
#undef YAMOR_GL_EXTENSION
}

std::string Describe(const GlFunctions& gl, const char* library) {
  auto text = [&](GLenum name) {
    const GLubyte* s = gl.GetString(name);
    return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("?");
  };
  return std::string(library) + ": " + text(GL_RENDERER) + ", " + text(GL_VERSION);
}

// ---- OSMesa -------------------------------------------------------------------

struct OsMesaLibrary {
  void* handle = nullptr;
  std::string error;  // why it is unavailable
  decltype(&::OSMesaCreateContextExt) CreateContextExt = nullptr;
  decltype(&::OSMesaMakeCurrent) MakeCurrent = nullptr;
  decltype(&::OSMesaDestroyContext) DestroyContext = nullptr;
  decltype(&::OSMesaGetProcAddress) GetProcAddress = nullptr;
  decltype(&::OSMesaPixelStore) PixelStore = nullptr;
};

// Loaded once per process and never unloaded (Mesa keeps threads and TLS).
const OsMesaLibrary& OsMesa() {
  static const OsMesaLibrary library = [] {
    OsMesaLibrary l;
    l.handle = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL);
    if (l.handle == nullptr) {
      l.error = "cannot load libOSMesa.so.8: " + DlError();
      return l;
    }
    auto sym = [&](auto& slot, const char* name) {
      slot = reinterpret_cast<std::remove_reference_t<decltype(slot)>>(dlsym(l.handle, name));
      if (slot == nullptr && l.error.empty()) l.error = std::string("libOSMesa.so.8 has no ") + name;
    };
    sym(l.CreateContextExt, "OSMesaCreateContextExt");
    sym(l.MakeCurrent, "OSMesaMakeCurrent");
    sym(l.DestroyContext, "OSMesaDestroyContext");
    sym(l.GetProcAddress, "OSMesaGetProcAddress");
    sym(l.PixelStore, "OSMesaPixelStore");
    return l;
  }();
  return library;
}

class OsMesaContext final : public GlContext {
 public:
  OsMesaContext() : lib_(OsMesa()) {
    if (!lib_.error.empty()) Unavailable(lib_.error);
    context_ = lib_.CreateContextExt(OSMESA_RGBA, 24, 8, 0, nullptr);
    if (context_ == nullptr) Unavailable("OSMesaCreateContextExt refused an RGBA context");
    Bind(probe_.data(), 1, 1);
    ResolveFunctions(
        gl_,
        [](const char* name, void* library) -> void* {
          void* p = reinterpret_cast<void*>(OsMesa().GetProcAddress(name));
          return p ? p : dlsym(library, name);
        },
        lib_.handle, "libOSMesa.so.8");
    description_ = Describe(gl_, "OSMesa");
  }

  ~OsMesaContext() override {
    if (context_ != nullptr) lib_.DestroyContext(context_);
  }

  void MakeCurrent(int width, int height, std::vector<uint8_t>& rgba) override {
    // OSMesa draws into user memory: the frame's own pixels, so the frame
    // needs no copy after glFinish.
    rgba.resize(static_cast<std::size_t>(width) * height * 4);
    Bind(rgba.data(), width, height);
  }

  void ReadPixels(int width, int height, std::vector<uint8_t>& rgba) override {
    YAMOR_CHECK(rgba.size() == static_cast<std::size_t>(width) * height * 4,
                "ReadPixels: not the frame given to MakeCurrent");
    gl_.Finish();  // OSMesa copies the frame into rgba
  }

  void Release() override {
    // OSMesaMakeCurrent(NULL, NULL, ...) unbinds whatever is current on this
    // thread (Render made this context current here).
    lib_.MakeCurrent(nullptr, nullptr, GL_UNSIGNED_BYTE, 0, 0);
  }

  GlLibrary library() const override { return GlLibrary::kOsMesa; }

 private:
  void Bind(uint8_t* pixels, int width, int height) {
    if (!lib_.MakeCurrent(context_, pixels, GL_UNSIGNED_BYTE, width, height)) {
      throw Error(StatusCode::kInternal, "OSMesaMakeCurrent failed for " +
                                             std::to_string(width) + "x" + std::to_string(height));
    }
    // Rows from the top, as images are.
    lib_.PixelStore(OSMESA_Y_UP, 0);
  }

  const OsMesaLibrary& lib_;
  OSMesaContext context_ = nullptr;
  std::array<uint8_t, 4> probe_{};  // the 1x1 target while the functions are resolved
};

// ---- EGL (surfaceless) -----------------------------------------------------------

struct EglLibrary {
  void* handle = nullptr;
  std::string error;
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLConfig config = nullptr;  // nullptr: EGL_NO_CONFIG_KHR
  decltype(&::eglGetProcAddress) GetProcAddress = nullptr;
  decltype(&::eglBindAPI) BindAPI = nullptr;
  decltype(&::eglCreateContext) CreateContext = nullptr;
  decltype(&::eglDestroyContext) DestroyContext = nullptr;
  decltype(&::eglMakeCurrent) MakeCurrent = nullptr;
  decltype(&::eglGetCurrentContext) GetCurrentContext = nullptr;
  decltype(&::eglGetError) GetError = nullptr;
};

const EglLibrary& Egl() {
  static const EglLibrary library = [] {
    EglLibrary l;
    l.handle = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
    if (l.handle == nullptr) {
      l.error = "cannot load libEGL.so.1: " + DlError();
      return l;
    }
    auto sym = [&](auto& slot, const char* name) {
      slot = reinterpret_cast<std::remove_reference_t<decltype(slot)>>(dlsym(l.handle, name));
      if (slot == nullptr && l.error.empty()) l.error = std::string("libEGL.so.1 has no ") + name;
    };
    decltype(&::eglInitialize) initialize = nullptr;
    decltype(&::eglQueryString) query_string = nullptr;
    decltype(&::eglChooseConfig) choose_config = nullptr;
    sym(l.GetProcAddress, "eglGetProcAddress");
    sym(l.BindAPI, "eglBindAPI");
    sym(l.CreateContext, "eglCreateContext");
    sym(l.DestroyContext, "eglDestroyContext");
    sym(l.MakeCurrent, "eglMakeCurrent");
    sym(l.GetCurrentContext, "eglGetCurrentContext");
    sym(l.GetError, "eglGetError");
    sym(initialize, "eglInitialize");
    sym(query_string, "eglQueryString");
    sym(choose_config, "eglChooseConfig");
    if (!l.error.empty()) return l;
    const char* client = query_string(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (client == nullptr || std::strstr(client, "EGL_MESA_platform_surfaceless") == nullptr) {
      l.error = "EGL has no surfaceless platform (EGL_MESA_platform_surfaceless)";
      return l;
    }
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
        l.GetProcAddress("eglGetPlatformDisplayEXT"));
    if (get_platform_display == nullptr) {
      l.error = "EGL has no eglGetPlatformDisplayEXT";
      return l;
    }
    l.display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    EGLint major = 0;
    EGLint minor = 0;
    if (l.display == EGL_NO_DISPLAY || !initialize(l.display, &major, &minor)) {
      l.error = "eglInitialize failed on the surfaceless platform (error 0x" +
                std::to_string(l.GetError()) + ")";
      return l;
    }
    const char* extensions = query_string(l.display, EGL_EXTENSIONS);
    if (extensions == nullptr || std::strstr(extensions, "EGL_KHR_surfaceless_context") == nullptr) {
      l.error = "EGL display has no EGL_KHR_surfaceless_context";
      return l;
    }
    if (std::strstr(extensions, "EGL_KHR_no_config_context") == nullptr) {
      const EGLint attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
      EGLint count = 0;
      if (!choose_config(l.display, attributes, &l.config, 1, &count) || count < 1) {
        l.error = "EGL has no OpenGL config";
        return l;
      }
    }
    return l;
  }();
  return library;
}

class EglContext final : public GlContext {
 public:
  EglContext() : lib_(Egl()) {
    if (!lib_.error.empty()) Unavailable(lib_.error);
    if (!lib_.BindAPI(EGL_OPENGL_API)) Unavailable("eglBindAPI(EGL_OPENGL_API) failed");
    context_ = lib_.CreateContext(lib_.display, lib_.config, EGL_NO_CONTEXT, nullptr);
    if (context_ == EGL_NO_CONTEXT) {
      Unavailable("eglCreateContext failed (error " + std::to_string(lib_.GetError()) + ")");
    }
    Bind();
    ResolveFunctions(
        gl_,
        [](const char* name, void*) -> void* {
          return reinterpret_cast<void*>(Egl().GetProcAddress(name));
        },
        nullptr, "EGL");
    description_ = Describe(gl_, "EGL surfaceless");
  }

  ~EglContext() override {
    if (framebuffer_ != 0 && lib_.GetCurrentContext() == context_) {
      gl_.DeleteRenderbuffers(2, renderbuffers_);
      gl_.DeleteFramebuffers(1, &framebuffer_);
    }
    if (lib_.GetCurrentContext() == context_) {
      lib_.MakeCurrent(lib_.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
    lib_.DestroyContext(lib_.display, context_);
  }

  void MakeCurrent(int width, int height, std::vector<uint8_t>& /*rgba*/) override {
    Bind();
    if (framebuffer_ == 0) {
      gl_.GenFramebuffers(1, &framebuffer_);
      gl_.GenRenderbuffers(2, renderbuffers_);
    }
    gl_.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
    if (width != width_ || height != height_) {
      gl_.BindRenderbuffer(GL_RENDERBUFFER, renderbuffers_[0]);
      gl_.RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
      gl_.BindRenderbuffer(GL_RENDERBUFFER, renderbuffers_[1]);
      gl_.RenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, width, height);
      gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER,
                                  renderbuffers_[0]);
      gl_.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER,
                                  renderbuffers_[1]);
      const GLenum status = gl_.CheckFramebufferStatus(GL_FRAMEBUFFER);
      if (status != GL_FRAMEBUFFER_COMPLETE) {
        throw Error(StatusCode::kInternal, "EGL framebuffer " + std::to_string(width) + "x" +
                                               std::to_string(height) + " incomplete: status " +
                                               std::to_string(status));
      }
      width_ = width;
      height_ = height;
    }
  }

  void ReadPixels(int width, int height, std::vector<uint8_t>& rgba) override {
    const std::size_t row = static_cast<std::size_t>(width) * 4;
    std::vector<uint8_t> flipped(row * height);
    gl_.PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl_.ReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, flipped.data());
    rgba.resize(row * height);
    for (int y = 0; y < height; ++y) {
      std::memcpy(&rgba[row * y], &flipped[row * (height - 1 - y)], row);
    }
  }

  void Release() override {
    if (lib_.GetCurrentContext() == context_) {
      lib_.MakeCurrent(lib_.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    }
  }

  GlLibrary library() const override { return GlLibrary::kEgl; }

 private:
  void Bind() {
    // The bound API is per thread: set it on whichever thread renders.
    lib_.BindAPI(EGL_OPENGL_API);
    if (!lib_.MakeCurrent(lib_.display, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      throw Error(StatusCode::kInternal,
                  "eglMakeCurrent failed (error " + std::to_string(lib_.GetError()) + ")");
    }
  }

  const EglLibrary& lib_;
  EGLContext context_ = EGL_NO_CONTEXT;
  GLuint framebuffer_ = 0;
  GLuint renderbuffers_[2] = {0, 0};
  int width_ = 0;
  int height_ = 0;
};

}  // namespace

std::unique_ptr<GlContext> CreateOsMesaContext() { return std::make_unique<OsMesaContext>(); }

std::unique_ptr<GlContext> CreateEglContext() { return std::make_unique<EglContext>(); }

}  // namespace yamor::render::internal
