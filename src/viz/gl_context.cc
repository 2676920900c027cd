#include "viz/gl_context.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLFW/glfw3.h>

#include <stdexcept>

#include "core/error.h"

namespace stance {

struct OffscreenGlContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLSurface surface = EGL_NO_SURFACE;
  EGLContext context = EGL_NO_CONTEXT;
  GLFWwindow* window = nullptr;

  // one EGL attempt on `d`; true when a context is current
  bool try_egl(EGLDisplay d) {
    if (d == EGL_NO_DISPLAY) return false;
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor)) return false;
    // clang-format off
    const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                     EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8,
                                     EGL_ALPHA_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_STENCIL_SIZE, 8,
                                     EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    // clang-format on
    EGLConfig config;
    EGLint n = 0;
    if (!eglChooseConfig(d, config_attribs, &config, 1, &n) || n < 1) {
      eglTerminate(d);
      return false;
    }
    // MuJoCo renders into its own offscreen framebuffer: a tiny pbuffer is enough
    const EGLint pbuffer_attribs[] = {EGL_WIDTH, 16, EGL_HEIGHT, 16, EGL_NONE};
    EGLSurface s = eglCreatePbufferSurface(d, config, pbuffer_attribs);
    if (!eglBindAPI(EGL_OPENGL_API)) {
      eglTerminate(d);
      return false;
    }
    EGLContext c = eglCreateContext(d, config, EGL_NO_CONTEXT, nullptr);
    if (c == EGL_NO_CONTEXT) {
      eglTerminate(d);
      return false;
    }
    if (!eglMakeCurrent(d, s, s, c)) {
      eglDestroyContext(d, c);
      eglTerminate(d);
      return false;
    }
    display = d;
    surface = s;
    context = c;
    return true;
  }
};

OffscreenGlContext::OffscreenGlContext() : impl_(std::make_unique<Impl>()) {
  // 1. EGL on Mesa's surfaceless platform: no display server at all
  auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
      eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (get_platform_display && impl_->try_egl(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA,
                                                                  EGL_DEFAULT_DISPLAY, nullptr))) {
    backend_ = "egl";
    return;
  }
  // 2. EGL's default display (a GPU driver, or X)
  if (impl_->try_egl(eglGetDisplay(EGL_DEFAULT_DISPLAY))) {
    backend_ = "egl";
    return;
  }
  // 3. a hidden GLFW window (X display, e.g. Xvfb)
  if (glfwInit()) {
    glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
    impl_->window = glfwCreateWindow(64, 64, "stance offscreen", nullptr, nullptr);
    glfwWindowHint(GLFW_VISIBLE, GLFW_TRUE);
    if (impl_->window) {
      glfwMakeContextCurrent(impl_->window);
      backend_ = "glfw";
      return;
    }
  }
  throw EnvironmentError(
      "no OpenGL context for offscreen rendering: tried EGL (surfaceless, default display) and "
      "a hidden GLFW window (set DISPLAY or run under xvfb-run)");
}

OffscreenGlContext::~OffscreenGlContext() {
  if (impl_->context != EGL_NO_CONTEXT) {
    eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(impl_->display, impl_->context);
    if (impl_->surface != EGL_NO_SURFACE) eglDestroySurface(impl_->display, impl_->surface);
    eglTerminate(impl_->display);
  }
  if (impl_->window) glfwDestroyWindow(impl_->window);
}

void OffscreenGlContext::make_current() {
  if (impl_->context != EGL_NO_CONTEXT)
    eglMakeCurrent(impl_->display, impl_->surface, impl_->surface, impl_->context);
  else if (impl_->window)
    glfwMakeContextCurrent(impl_->window);
}

}  // namespace stance
