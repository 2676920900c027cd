// Transitional: a controller written as one mutable object (its model and its state together)
// runs as an immutable model whose per-run state is a copy of a prototype built once. Every
// controller moves to TypedController with a State of its own; this file goes when none is left.
#pragma once

#include "control/controller.h"

namespace stance {

class LegacyController {
 public:
  virtual ~LegacyController() = default;
  virtual std::string_view type() const = 0;
  virtual void reset(const Engine& engine) = 0;
  virtual void compute(const Engine& engine, ControlOutput& out) = 0;
  virtual void signal_names(std::vector<std::string>& names) const {}
  virtual void signals(std::vector<double>& values) const {}
  virtual void add_metrics(nlohmann::json& metrics) const {}
  virtual void write_outputs(const std::string& out_dir) const {}
  virtual YAML::Node params_yaml() const = 0;
  virtual std::vector<ParamEntry> tunable_params() const {
    std::vector<ParamEntry> out;
    list_yaml_params(params_yaml(), "", out);
    return out;
  }
  virtual void markers(const Engine& engine, std::vector<Marker>& out) const {}
  virtual bool reference_qpos(const Engine& engine, Eigen::VectorXd& qpos) const { return false; }
  virtual bool initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                             Eigen::VectorXd& qvel) const {
    return false;
  }
};

template <class C>
class LegacyModel final : public TypedController<C> {
 public:
  explicit LegacyModel(C prototype) : proto_(std::move(prototype)) {}
  std::string_view type() const override { return proto_.type(); }
  YAML::Node params_yaml() const override { return proto_.params_yaml(); }
  std::vector<ParamEntry> tunable_params() const override { return proto_.tunable_params(); }
  void signal_names(std::vector<std::string>& names) const override { proto_.signal_names(names); }
  bool initial_state(const Engine& engine, Eigen::VectorXd& qpos,
                     Eigen::VectorXd& qvel) const override {
    return proto_.initial_state(engine, qpos, qvel);
  }
  // the state is the whole old object, parameters included: an edit starts it afresh
  bool keeps_state_of(const Controller& previous) const override { return false; }
  const C& prototype() const { return proto_; }

 protected:
  std::unique_ptr<StateOf<C>> allocate_state() const override {
    return std::make_unique<StateOf<C>>(proto_);
  }
  void reset_state(C& s, const Engine& engine) const override {
    s = proto_;
    s.reset(engine);
  }
  void compute_step(C& s, const Engine& engine, ControlOutput& out) const override {
    s.compute(engine, out);
  }
  void state_signals(const C& s, std::vector<double>& values) const override { s.signals(values); }
  void state_metrics(const C& s, nlohmann::json& metrics) const override { s.add_metrics(metrics); }
  void state_outputs(const C& s, const std::string& out_dir) const override {
    s.write_outputs(out_dir);
  }
  void state_markers(const C& s, const Engine& engine, std::vector<Marker>& out) const override {
    s.markers(engine, out);
  }
  bool state_reference_qpos(const C& s, const Engine& engine,
                            Eigen::VectorXd& qpos) const override {
    return s.reference_qpos(engine, qpos);
  }

 private:
  C proto_;
};

}  // namespace stance
