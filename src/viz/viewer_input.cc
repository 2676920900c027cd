#include "viz/viewer.h"

#include "viz/viewer_impl.h"

namespace stance {

namespace {
constexpr double kDoubleClickS = 0.3;
}  // namespace

void Viewer::Impl::install_input_callbacks() {
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    if (ImGui::GetCurrentContext() && ImGui::GetIO().WantCaptureKeyboard) return;
    static_cast<Viewer*>(glfwGetWindowUserPointer(w))->key(key);
  });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int mods) {
    Viewer& viewer = *static_cast<Viewer*>(glfwGetWindowUserPointer(w));
    Impl& s = *viewer.impl_;
    bool down = action == GLFW_PRESS && !ImGui::GetIO().WantCaptureMouse;
    if (button == GLFW_MOUSE_BUTTON_LEFT) s.button_left = down;
    if (button == GLFW_MOUSE_BUTTON_RIGHT) s.button_right = down;
    glfwGetCursorPos(w, &s.last_x, &s.last_y);
    if (!down) {
      // letting go of the button ends the pull; the selection stays
      if (s.drag_plane != 0) viewer.release();
      s.drag_plane = 0;
      return;
    }
    if (button == GLFW_MOUSE_BUTTON_LEFT) {
      double now = glfwGetTime();
      bool double_click = now - s.last_left_press < kDoubleClickS;
      s.last_left_press = double_click ? -1 : now;
      if (double_click) {
        viewer.select_at(s.last_x, s.last_y);
        return;
      }
    }
    if ((mods & GLFW_MOD_CONTROL) && viewer.selected_body() >= 0) {
      // the pull starts at the selected point
      std::lock_guard<std::mutex> lock(s.mutex);
      s.drag_plane = button == GLFW_MOUSE_BUTTON_RIGHT ? 1 : 2;
      s.run->engine().forward();
      s.drag_target = s.selected_point(s.run->engine());
      s.dragging = true;
    }
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) {
    Impl& s = *static_cast<Viewer*>(glfwGetWindowUserPointer(w))->impl_;
    double dx = x - s.last_x, dy = y - s.last_y;
    s.last_x = x;
    s.last_y = y;
    if (!s.button_left && !s.button_right) return;
    int width = 1, height = 1;
    glfwGetWindowSize(w, &width, &height);
    if (s.drag_plane != 0) {
      std::lock_guard<std::mutex> lock(s.mutex);
      s.drag_target +=
          s.view->mouse_motion_in_world(dx, dy, height, s.drag_target, s.drag_plane == 2);
      return;
    }
    int action = s.button_right ? mjMOUSE_MOVE_H : mjMOUSE_ROTATE_H;
    // panning moves the look-at point: that is the free camera
    if (s.button_right) s.view->options.camera = CameraMode::kFree;
    mjv_moveCamera(s.view->draw_model(), action, dx / height, dy / height, &s.view->scene(),
                   &s.view->camera());
  });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    Impl& s = *static_cast<Viewer*>(glfwGetWindowUserPointer(w))->impl_;
    if (ImGui::GetIO().WantCaptureMouse) return;
    mjv_moveCamera(s.view->draw_model(), mjMOUSE_ZOOM, 0, -0.05 * dy, &s.view->scene(),
                   &s.view->camera());
  });
}

void Viewer::key(int k) {
  Impl& s = *impl_;
  std::lock_guard<std::mutex> lock(s.mutex);
  Engine& e = s.run->engine();
  switch (k) {
    case GLFW_KEY_SPACE:
      s.paused = !s.paused;
      if (!s.paused) s.resume_from_scrub();
      s.anchor_dirty = true;
      break;
    case GLFW_KEY_N:
      if (!s.paused) s.paused = true;
      if (s.options.threaded)
        ++s.single_steps;
      else
        s.step_locked();
      break;
    case GLFW_KEY_P:
      s.replay();
      s.status = "replay from the start";
      break;
    case GLFW_KEY_R:
      try {
        if (s.recording) {
          s.stop_recording();
        } else {
          int width = 0, height = 0;
          glfwGetFramebufferSize(s.window, &width, &height);
          s.start_recording(width, height);
        }
      } catch (const std::exception& err) {
        s.recording.reset();
        s.status = err.what();
        std::cout << s.status << std::endl;
      }
      break;
    case GLFW_KEY_I:
      // a running window keeps no frames: the next one is read back and saved
      if (s.options.threaded && !s.recording)
        s.capture_png = true;
      else
        s.save_png();
      break;
    case GLFW_KEY_COMMA:
    case GLFW_KEY_PERIOD: {
      // back (-x) or forth (+x) in the view's horizontal frame
      Eigen::Vector3d forth = Eigen::Vector3d::UnitX() - s.up.dot(Eigen::Vector3d::UnitX()) * s.up;
      if (forth.norm() < 1e-6) forth = Eigen::Vector3d::UnitY();
      forth.normalize();
      double sign = k == GLFW_KEY_PERIOD ? 1.0 : -1.0;
      s.add_key_push(e, sign * s.push_newtons * forth);
      s.status = fmt::format("push {:.0f} N {} on {}", s.push_newtons, sign > 0 ? "forth" : "back",
                             e.body_name(s.push_body));
      break;
    }
    case GLFW_KEY_A:
    case GLFW_KEY_S: {
      // the skateboard speed: the first parameter named "speed" (or "..._speed"), changed by
      // its "<name>_step" sibling when there is one (the seed's speed increment), else 0.1
      double sign = k == GLFW_KEY_S ? 1.0 : -1.0;
      auto ends_with = [](const std::string& a, const std::string& b) {
        return a.size() >= b.size() && a.compare(a.size() - b.size(), b.size(), b) == 0;
      };
      for (size_t i = 0; i < s.entries.size(); ++i)
        for (const auto& entry : s.entries[i]) {
          if (entry.path != "speed" && !ends_with(entry.path, "_speed") &&
              !ends_with(entry.path, ".speed"))
            continue;
          double step = 0.1;
          for (const auto& other : s.entries[i])
            if (other.path == entry.path + "_step" && other.value > 0) step = other.value;
          double value = entry.value + sign * step;
          std::string path = entry.path;
          try {
            s.retune(static_cast<int>(i), path, value);
          } catch (const std::exception& err) {
            s.status = err.what();
          }
          return;
        }
      s.status = "this scenario has no speed parameter";
      break;
    }
    case GLFW_KEY_MINUS:
      s.speed = std::max(1.0 / 64, s.speed / 2);
      s.anchor_dirty = true;
      break;
    case GLFW_KEY_EQUAL:
      s.speed = std::min(16.0, s.speed * 2);
      s.anchor_dirty = true;
      break;
    case GLFW_KEY_F:
      s.view->options.camera =
          s.view->options.camera == CameraMode::kFollow ? CameraMode::kFree : CameraMode::kFollow;
      break;
    case GLFW_KEY_C:
      s.view->options.contacts = !s.view->options.contacts;
      break;
    case GLFW_KEY_M:
      s.view->options.com = !s.view->options.com;
      break;
    case GLFW_KEY_K:
      s.view->options.markers = !s.view->options.markers;
      break;
    case GLFW_KEY_G:
      s.view->options.ghost = !s.view->options.ghost;
      break;
    case GLFW_KEY_H:
      s.show_help = !s.show_help;
      break;
    case GLFW_KEY_ESCAPE:
      glfwSetWindowShouldClose(s.window, GLFW_TRUE);
      break;
    default:
      break;
  }
}

bool Viewer::select_body(const std::string& name) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Impl& s = *impl_;
  Engine& e = s.run->engine();
  int b = e.body_index(name);
  if (b < 0) return false;
  e.forward();
  BodyPose pose = e.body_pose(b);
  s.selected = b;
  s.selected_local = pose.quat.conjugate() * (e.body_com(b) - pose.pos);
  s.dragging = false;
  s.status = "selected " + name;
  return true;
}

bool Viewer::select_at(double x, double y) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  Impl& s = *impl_;
  int width = 1, height = 1;
  glfwGetWindowSize(s.window, &width, &height);
  Engine& e = s.run->engine();
  Eigen::Vector3d point;
  int b = s.view->pick_body(x / width, 1.0 - y / height, double(width) / height, point);
  s.dragging = false;
  if (b < 0) {
    s.selected = -1;
    s.status = "released";
    return false;
  }
  e.forward();
  BodyPose pose = e.body_pose(b);
  s.selected = b;
  s.selected_local = pose.quat.conjugate() * (point - pose.pos);
  s.status = "selected " + e.body_name(b) + " (ctrl+drag pulls it)";
  return true;
}

void Viewer::drag_to(const Eigen::Vector3d& target) {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  if (impl_->selected < 0) return;
  impl_->drag_target = target;
  impl_->dragging = true;
}

void Viewer::release() {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  impl_->dragging = false;
}

int Viewer::selected_body() const {
  std::lock_guard<std::mutex> lock(impl_->mutex);
  return impl_->selected;
}

}  // namespace stance
