// An OpenGL context for MuJoCo's renderer with no window on screen: EGL (Mesa's surfaceless
// platform, then the default display), falling back to a hidden GLFW window (needs an X display,
// e.g. under Xvfb). MuJoCo 2.2.2's mjr_makeContext needs a current context; this makes one.
#pragma once

#include <memory>
#include <string>

namespace stance {

class OffscreenGlContext {
 public:
  // throws EnvironmentError listing what was tried when no context can be made
  OffscreenGlContext();
  ~OffscreenGlContext();
  OffscreenGlContext(const OffscreenGlContext&) = delete;
  OffscreenGlContext& operator=(const OffscreenGlContext&) = delete;

  void make_current();
  const std::string& backend() const { return backend_; }  // "egl" or "glfw"

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string backend_;
};

}  // namespace stance
