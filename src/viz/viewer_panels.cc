#include "viz/viewer.h"

#include "viz/viewer_impl.h"

namespace stance {

namespace {
const char* kHelpText =
    "space   pause / run\n"
    "n       single step (while paused)\n"
    "p       replay from the start\n"
    "r       record an MP4 of the window / stop\n"
    "i       save a PNG of the window\n"
    ", .     push back / forth on the push body\n"
    "a s     skateboard speed down / up\n"
    "- =     slower / faster than real time\n"
    "f       camera: follow the root / free\n"
    "c       contact points and forces\n"
    "m       COM and support markers\n"
    "k       controller markers (SIMBICON circles)\n"
    "g       tracking ghost (reference pose)\n"
    "h       this help\n"
    "Esc     quit\n"
    "mouse   left drag: rotate, right drag: pan, wheel: zoom\n"
    "        double-click: select a body (empty space: release)\n"
    "        ctrl+right drag: pull it in the screen plane\n"
    "        ctrl+left drag: pull it along the ground\n"
    "paused  the history slider scrubs; space runs on from there";
}  // namespace

void Viewer::Impl::draw_param_group(
    const ParamGroup& group, std::vector<ParamEntry>& list, int depth,
    const std::function<void(const std::string&, double)>& changed) {
  for (int index : group.entries) {
    ParamEntry& entry = list[index];
    std::string label = fmt::format("{}##{}", param_label(entry), entry.path);
    if (entry.kind == ParamEntry::Kind::kBool) {
      bool b = entry.value != 0;
      if (ImGui::Checkbox(label.c_str(), &b)) changed(entry.path, b ? 1 : 0);
    } else {
      double v = entry.value;
      bool bounded = std::isfinite(entry.meta.min) && std::isfinite(entry.meta.max);
      double lo = std::isfinite(entry.meta.min) ? entry.meta.min : -1e9;
      double hi = std::isfinite(entry.meta.max) ? entry.meta.max : 1e9;
      // unbounded or wide ranges: drag around the value; narrow ones: a slider
      if (bounded && hi - lo <= 100) {
        ImGui::SliderScalar(label.c_str(), ImGuiDataType_Double, &v, &lo, &hi, "%.4g");
      } else {
        float speed = static_cast<float>(std::max(1e-3, 0.01 * std::abs(v)));
        ImGui::DragScalar(label.c_str(), ImGuiDataType_Double, &v, speed, &lo, &hi, "%.4g");
      }
      if (v != entry.value) entry.value = v;  // shown while dragging
      if (ImGui::IsItemDeactivatedAfterEdit()) changed(entry.path, v);
    }
    if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", param_tooltip(entry).c_str());
  }
  bool filtering = param_filter[0] != 0;
  for (const auto& sub : group.groups) {
    // the controller's own structs open; the lists' elements (FSM states) start closed
    bool element = sub.name.find(' ') != std::string::npos;
    if (filtering) ImGui::SetNextItemOpen(true);
    ImGuiTreeNodeFlags flags = element || depth > 1 ? 0 : ImGuiTreeNodeFlags_DefaultOpen;
    if (ImGui::TreeNodeEx(sub.name.c_str(), flags)) {
      draw_param_group(sub, list, depth + 1, changed);
      ImGui::TreePop();
    }
  }
}

void Viewer::Impl::draw_panels() {
  // panels take at most 30% of the width each, so that the character stays in view
  float panel_w = std::min(360.0f, 0.3f * options.width);
  draw_state_panel(panel_w);
  draw_param_panel(panel_w);
  if (show_help) draw_help();
}

void Viewer::Impl::draw_state_panel(float panel_w) {
  Engine& e = run->engine();
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(panel_w, 0.6f * options.height), ImGuiCond_FirstUseEver);
  ImGui::Begin("stance");
  ImGui::Text("%s on %s", loaded.scenario.name.c_str(), std::string(e.engine_name()).c_str());
  ImGui::Text("t = %.3f s  %s", e.time(), paused ? "(paused)" : "");
  ImGui::Text("speed x%.3g requested, x%.2f achieved", speed, achieved_speed);
  float sp = static_cast<float>(speed);
  if (ImGui::SliderFloat("speed", &sp, 1.0f / 64, 16.0f, "x%.3f", ImGuiSliderFlags_Logarithmic)) {
    speed = sp;
    anchor_dirty = true;
  }
  if (ImGui::Button(paused ? "run" : "pause")) {
    paused = !paused;
    if (!paused) resume_from_scrub();
    anchor_dirty = true;
  }
  ImGui::SameLine();
  if (ImGui::Button("step")) {
    paused = true;
    step_locked();
  }
  ImGui::SameLine();
  if (ImGui::Button("replay")) replay();
  ImGui::SameLine();
  if (ImGui::Button("save scenario")) {
    try {
      status = "wrote " + write_tuned("");
    } catch (const std::exception& err) {
      status = err.what();
    }
  }
  bool follow = view->options.camera == CameraMode::kFollow;
  if (ImGui::Checkbox("follow", &follow))
    view->options.camera = follow ? CameraMode::kFollow : CameraMode::kFree;
  ImGui::SameLine();
  ImGui::Checkbox("contacts", &view->options.contacts);
  ImGui::SameLine();
  ImGui::Checkbox("COM", &view->options.com);
  ImGui::SameLine();
  ImGui::Checkbox("help", &show_help);
  ImGui::Checkbox("markers", &view->options.markers);
  ImGui::SameLine();
  ImGui::Checkbox("ghost", &view->options.ghost);
  if (selected >= 0) {
    ImGui::SameLine();
    ImGui::Text("selected: %s", e.body_name(selected).c_str());
  }
  // the timeline: while paused, any recorded state
  if (paused && history.size() > 1) {
    int n = static_cast<int>(history.size());
    int shown = scrubbed >= 0 ? scrubbed : n - 1;
    std::string label = fmt::format("t = {:.3f} s", history[shown].time);
    if (ImGui::SliderInt("history", &shown, 0, n - 1, label.c_str())) {
      e.restore_state(history[shown]);
      e.forward();
      scrubbed = shown;
    }
  }
  if (!pending.empty())
    ImGui::Text("rebuilding %d controller(s) in the background", int(pending.size()));
  if (!status.empty()) ImGui::TextWrapped("%s", status.c_str());

  // live plots over the rolling window
  if (ImGui::CollapsingHeader("plots", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (const auto& p : plots) {
      float last = p.values[(p.head + p.values.size() - 1) % p.values.size()];
      std::string label = fmt::format("{}\n{:.3g}", p.name, last);
      ImGui::PlotLines(fmt::format("##{}", p.name).c_str(), p.values.data(),
                       static_cast<int>(p.values.size()), p.head, label.c_str(), FLT_MAX, FLT_MAX,
                       ImVec2(panel_w - 30, 45));
    }
  }
  ImGui::End();
}

void Viewer::Impl::draw_param_panel(float panel_w) {
  // parameters, generated from the controllers' visits: grouped by controller and by their
  // structs (FSM states collapse), labelled from the visit, full path and help on hover
  // wide enough for the longest label (at the deepest indent) and a 120 px field
  float label_w = 0;
  for (const auto& list : entries)
    for (const auto& entry : list)
      label_w = std::max(label_w, ImGui::CalcTextSize(param_label(entry).c_str()).x);
  for (const auto& entry : planner_entries)
    label_w = std::max(label_w, ImGui::CalcTextSize(param_label(entry).c_str()).x);
  label_w += 4 * ImGui::GetStyle().IndentSpacing;
  float params_w = std::clamp(label_w + 150.0f, panel_w, 0.45f * options.width);
  ImGui::SetNextWindowPos(ImVec2(options.width - params_w - 10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(params_w, 0.7f * options.height), ImGuiCond_FirstUseEver);
  ImGui::Begin("parameters");
  ImGui::SetNextItemWidth(-1);
  ImGui::InputTextWithHint("##filter", "filter (name, unit, help)", param_filter,
                           sizeof(param_filter));
  // the value fields take what the labels leave: labels are short now
  ImGui::PushItemWidth(-std::min(label_w, ImGui::GetWindowWidth() - 120.0f));
  int changed_controller = -1;
  std::string changed_path;
  double changed_value = 0;
  bool filtering = param_filter[0] != 0;
  for (size_t i = 0; i < entries.size(); ++i) {
    ParamGroup tree = build_param_tree(entries[i], param_filter);
    if (filtering && tree.size() == 0) continue;
    std::string header = fmt::format("{} [{}]", run->controllers()[i]->type(), i);
    if (filtering) ImGui::SetNextItemOpen(true);
    if (!ImGui::CollapsingHeader(header.c_str(), ImGuiTreeNodeFlags_DefaultOpen)) continue;
    ImGui::PushID(static_cast<int>(i));
    draw_param_group(tree, entries[i], 0, [&](const std::string& path, double value) {
      changed_controller = static_cast<int>(i);
      changed_path = path;
      changed_value = value;
    });
    ImGui::PopID();
  }
  // the planner block, when the run plans: its edits take effect at the next step
  constexpr int kPlanner = -2;
  ParamGroup planner_tree = build_param_tree(planner_entries, param_filter);
  if (!planner_entries.empty() && !(filtering && planner_tree.size() == 0)) {
    if (filtering) ImGui::SetNextItemOpen(true);
    if (ImGui::CollapsingHeader("planner", ImGuiTreeNodeFlags_DefaultOpen)) {
      ImGui::PushID(kPlanner);
      draw_param_group(planner_tree, planner_entries, 0,
                       [&](const std::string& path, double value) {
                         changed_controller = kPlanner;
                         changed_path = path;
                         changed_value = value;
                       });
      ImGui::PopID();
    }
  }
  ImGui::PopItemWidth();
  ImGui::End();
  if (changed_controller != -1) {
    try {
      if (changed_controller == kPlanner) {
        retune_planner(*run, changed_path, changed_value);
        status = fmt::format("planner.{} = {:.4g}", changed_path, changed_value);
        refresh_entries();
      } else {
        retune(changed_controller, changed_path, changed_value);
      }
    } catch (const std::exception& err) {
      status = err.what();
      refresh_entries();
    }
  }
}

void Viewer::Impl::draw_help() {
  // at the bottom left, tall enough for every line
  int lines = 1 + static_cast<int>(std::count(kHelpText, kHelpText + std::strlen(kHelpText), '\n'));
  float help_h = lines * ImGui::GetTextLineHeight() + 35.0f;
  ImGui::SetNextWindowPos(ImVec2(10, options.height - help_h), ImGuiCond_FirstUseEver);
  ImGui::Begin("keys", &show_help, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::TextUnformatted(kHelpText);
  ImGui::End();
}

}  // namespace stance
