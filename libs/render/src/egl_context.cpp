// Headless OpenGL through EGL: Mesa's surfaceless platform (no display, no GPU needed: llvmpipe),
// else an EGL device (a GPU without a display server), else the default display. No pbuffer:
// everything renders into framebuffer objects.
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <cstring>
#include <future>
#include <iostream>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "gl.h"
#include "sawyer/render/gl_context.h"

namespace sawyer::render {
namespace {

std::string egl_error_name(EGLint e) {
  switch (e) {
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    default:
      return "EGL error " + std::to_string(e);
  }
}

// Contexts alive per EGL display: EGL displays are per process (the same handle for every
// context on a platform), so a display is terminated only when its last context goes.
std::mutex g_displays_mutex;
std::map<EGLDisplay, int> g_display_users;

void release_display(EGLDisplay d) {
  std::lock_guard<std::mutex> lock(g_displays_mutex);
  if (g_display_users[d] <= 0) eglTerminate(d);
}

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

void APIENTRY debug_callback(GLenum, GLenum type, GLuint, GLenum severity, GLsizei,
                             const GLchar* message, const void*) {
  if (severity == GL_DEBUG_SEVERITY_NOTIFICATION) return;
  std::cerr << "GL debug (" << (type == GL_DEBUG_TYPE_ERROR ? "error" : "note") << "): " << message
            << "\n";
}

class EglContext final : public GlContext {
 public:
  EglContext(EGLDisplay d, EGLContext c, std::string platform)
      : display_(d), context_(c), platform_(std::move(platform)) {
    std::lock_guard<std::mutex> lock(g_displays_mutex);
    ++g_display_users[display_];
  }
  ~EglContext() override {
    if (eglGetCurrentContext() == context_)
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    {
      std::lock_guard<std::mutex> lock(g_displays_mutex);
      --g_display_users[display_];
    }
    release_display(display_);
  }
  bool make_current() override {
    return eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_) == EGL_TRUE;
  }
  std::string description() const override {
    return describe_current_context() + ", EGL " + platform_;
  }

 private:
  EGLDisplay display_;
  EGLContext context_;
  std::string platform_;
};

// Tries to make a 4.5 (then 4.3) core context current on `d`; returns the context or an error.
Result<EGLContext> make_context(EGLDisplay d, bool debug) {
  EGLint major = 0, minor = 0;
  if (!eglInitialize(d, &major, &minor))
    return Error("eglInitialize: " + egl_error_name(eglGetError()));
  if (!eglBindAPI(EGL_OPENGL_API)) {
    release_display(d);
    return Error("eglBindAPI(OpenGL): " + egl_error_name(eglGetError()));
  }
  const char* ext = eglQueryString(d, EGL_EXTENSIONS);
  if (!has_extension(ext, "EGL_KHR_surfaceless_context")) {
    release_display(d);
    return Error("the display lacks EGL_KHR_surfaceless_context");
  }
  EGLConfig config = nullptr;
  EGLint n = 0;
  const EGLint cfg_attr[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  eglChooseConfig(d, cfg_attr, &config, 1, &n);
  const bool no_config = has_extension(ext, "EGL_KHR_no_config_context") ||
                         has_extension(ext, "EGL_MESA_configless_context");
  if (n < 1 && !no_config) {
    release_display(d);
    return Error("no EGL config renders OpenGL");
  }
  std::string last;
  for (int minor_version : {5, 3}) {
    const EGLint attr[] = {EGL_CONTEXT_MAJOR_VERSION,
                           4,
                           EGL_CONTEXT_MINOR_VERSION,
                           minor_version,
                           EGL_CONTEXT_OPENGL_PROFILE_MASK,
                           EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                           EGL_CONTEXT_OPENGL_DEBUG,
                           debug ? EGL_TRUE : EGL_FALSE,
                           EGL_NONE};
    EGLContext c = eglCreateContext(d, n > 0 ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attr);
    if (c == EGL_NO_CONTEXT) {
      last = "eglCreateContext(OpenGL 4." + std::to_string(minor_version) +
             " core): " + egl_error_name(eglGetError());
      continue;
    }
    if (!eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, c)) {
      last = "eglMakeCurrent: " + egl_error_name(eglGetError());
      eglDestroyContext(d, c);
      continue;
    }
    return c;
  }
  release_display(d);
  return Error(last);
}

}  // namespace

std::string describe_current_context() {
  const GLubyte* version = glGetString(GL_VERSION);
  const GLubyte* renderer = glGetString(GL_RENDERER);
  if (!version || !renderer) return {};
  return "OpenGL " + std::string(reinterpret_cast<const char*>(version)) + ", " +
         reinterpret_cast<const char*>(renderer);
}

namespace {

Result<std::unique_ptr<GlContext>> make_headless_context(const HeadlessContextOptions& options) {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  std::vector<std::string> tried;
  auto attempt = [&](EGLDisplay d, const std::string& platform) -> std::unique_ptr<GlContext> {
    if (d == EGL_NO_DISPLAY) {
      tried.push_back(platform + ": no display");
      return nullptr;
    }
    Result<EGLContext> c = make_context(d, options.debug);
    if (!c) {
      tried.push_back(platform + ": " + c.error().message());
      return nullptr;
    }
    if (options.debug) {
      glEnable(GL_DEBUG_OUTPUT);
      glDebugMessageCallback(debug_callback, nullptr);
    }
    return std::make_unique<EglContext>(d, c.value(), platform);
  };

  if (options.try_surfaceless && get_platform_display &&
      has_extension(client, "EGL_MESA_platform_surfaceless")) {
    if (auto ctx = attempt(
            get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr),
            "surfaceless"))
      return ctx;
  }
  if (options.try_device && get_platform_display &&
      has_extension(client, "EGL_EXT_platform_device")) {
    auto query_devices =
        reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    EGLDeviceEXT devices[16];
    EGLint count = 0;
    if (query_devices && query_devices(16, devices, &count)) {
      for (EGLint i = 0; i < count; ++i) {
        if (auto ctx = attempt(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr),
                               "device " + std::to_string(i)))
          return ctx;
      }
    }
  }
  if (auto ctx = attempt(eglGetDisplay(EGL_DEFAULT_DISPLAY), "default display")) return ctx;
  std::string why;
  for (const std::string& t : tried) why += (why.empty() ? "" : "; ") + t;
  return Error("headless OpenGL",
               "no EGL context (" + (why.empty() ? "no EGL platform" : why) + ")");
}

}  // namespace

namespace {
std::mutex g_prewarm_mutex;
std::future<std::unique_ptr<GlContext>> g_prewarm;  // guarded by g_prewarm_mutex; null: failed

bool default_options(const HeadlessContextOptions& o) {
  const HeadlessContextOptions d;
  return o.try_surfaceless == d.try_surfaceless && o.try_device == d.try_device &&
         o.debug == d.debug;
}
}  // namespace

void prewarm_headless_context() {
  std::lock_guard<std::mutex> lock(g_prewarm_mutex);
  if (g_prewarm.valid()) return;
  g_prewarm = std::async(std::launch::async, []() -> std::unique_ptr<GlContext> {
    Result<std::unique_ptr<GlContext>> c = make_headless_context({});
    if (!c) return nullptr;  // the taker makes its own, and reports its own error
    // Not current here any more, so that the taker's thread can make it current.
    eglMakeCurrent(eglGetCurrentDisplay(), EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    return std::move(c.value());
  });
}

// The context prewarm_headless_context() made, current on this thread; null when there is none
// (none asked for, or its making failed: the caller then makes one and reports its own error).
std::unique_ptr<GlContext> take_prewarmed() {
  std::future<std::unique_ptr<GlContext>> waiting;
  {
    std::lock_guard<std::mutex> lock(g_prewarm_mutex);
    waiting = std::move(g_prewarm);
  }
  if (!waiting.valid()) return nullptr;
  std::unique_ptr<GlContext> ctx = waiting.get();
  if (ctx && !ctx->make_current()) ctx.reset();
  return ctx;
}

void drop_prewarmed_headless_context() { take_prewarmed().reset(); }

Result<std::unique_ptr<GlContext>> create_headless_context(const HeadlessContextOptions& options) {
  if (default_options(options))
    if (std::unique_ptr<GlContext> ctx = take_prewarmed()) return ctx;
  return make_headless_context(options);
}

}  // namespace sawyer::render
