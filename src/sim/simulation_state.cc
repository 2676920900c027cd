// Branching a simulation (save, restore, clone) and its state file.
#include "sim/simulation.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <set>
#include <sstream>
#include <typeinfo>

#include "control/standing_pose.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/model_format.h"
#include "core/timestep.h"
#include "engine/world_spec.h"
#include "model/model_path.h"
#include "model/robot_model.h"
#include "sim/observers.h"

namespace stance {

// ---- branching and the state file

void Simulation::save(SimulationState& state) const {
  engine_->save_state(state.engine);
  state.progress = progress_;
  state.controllers.resize(states_.size());
  for (size_t i = 0; i < states_.size(); ++i) {
    if (state.controllers[i] && same_state_type(*state.controllers[i], *states_[i]))
      state.controllers[i]->assign(*states_[i]);
    else
      state.controllers[i] = states_[i]->clone();
  }
}

void Simulation::restore(const SimulationState& state) {
  if (state.controllers.size() != states_.size())
    throw std::logic_error("restore: a state of another simulation");
  engine_->restore_state(state.engine);
  engine_->forward();
  held_steps_left_ = 0;  // the restored state's controls are computed, not held
  for (size_t i = 0; i < states_.size(); ++i) {
    if (same_state_type(*states_[i], *state.controllers[i]))
      states_[i]->assign(*state.controllers[i]);
    else
      states_[i] = state.controllers[i]->clone();
  }
  // the engine goes on with the servo commands of the saved moment: only those that differ
  // from what it holds now are sent (a release on a dof that never had one is not)
  Eigen::VectorXd held = progress_.velocity_sent;
  progress_ = state.progress;
  progress_.velocity_sent = held;
  send_velocity_commands(state.progress.velocity_sent);
}

std::unique_ptr<Simulation> Simulation::clone() const {
  auto sim = std::make_unique<Simulation>(model_);
  for (size_t i = 0; i < controllers_.size(); ++i)
    if (i >= sim->controllers_.size()) {
      sim->add_controller(controllers_[i]);
    } else if (sim->controllers_[i] != controllers_[i]) {
      sim->controllers_[i] = controllers_[i];
      sim->states_[i] = controllers_[i]->make_state(*sim->engine_);
    }
  SimulationState state;
  save(state);
  sim->restore(state);
  return sim;
}

namespace {
// 3: the plan counts its rescue rounds; 4: and its steps on track and rollout steps; 5: each
// dof's steps at its torque limit and largest request over it; 6: the plan's calm streak
constexpr char kStateMagic[] = "stance-state 6\n";
}  // namespace

void Simulation::write_state(const std::string& path) const {
  std::string out = kStateMagic;
  StateWriter w(out);
  const Engine& e = *engine_;
  w(std::string(e.engine_name())), w(e.nq()), w(e.nv()), w(e.nu());
  EngineState es;
  e.save_state(es);
  w(es.time), w(es.q), w(es.v), w(es.act), w(es.ctrl), w(es.extra);
  w(const_cast<RunProgress&>(progress_).steps);
  const_cast<RunProgress&>(progress_).serialize(w);
  w(controllers_.size());
  for (size_t i = 0; i < controllers_.size(); ++i) {
    w(std::string(controllers_[i]->type()));
    states_[i]->write(out);
  }
  write_file_atomically(path, out);
}

void Simulation::read_state(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot read the state file", path));
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string magic = kStateMagic;
  if (data.compare(0, magic.size(), magic) != 0)
    throw InputError(fmt::format(
        "{}: not a stance state file, or one written by another stance version (this one reads "
        "'{}')",
        path, magic.substr(0, magic.size() - 1)));
  const Engine& e = *engine_;
  try {
    StateReader r(data, magic.size());
    std::string engine_name;
    int nq = 0, nv = 0, nu = 0;
    r(engine_name), r(nq), r(nv), r(nu);
    if (engine_name != e.engine_name() || nq != e.nq() || nv != e.nv() || nu != e.nu())
      throw InputError(fmt::format(
          "{}: a state of another model ({} nq {} nv {} nu {}; this run: {} nq {} nv {} nu {})",
          path, engine_name, nq, nv, nu, e.engine_name(), e.nq(), e.nv(), e.nu()));
    SimulationState state;
    r(state.engine.time), r(state.engine.q), r(state.engine.v), r(state.engine.act);
    r(state.engine.ctrl), r(state.engine.extra);
    long steps = 0;
    r(steps);
    state.progress.serialize(r);
    size_t n = 0;
    r(n);
    if (n != controllers_.size())
      throw InputError(
          fmt::format("{}: {} controllers, this scenario has {}", path, n, controllers_.size()));
    size_t offset = r.position();
    for (size_t i = 0; i < n; ++i) {
      StateReader tr(data, offset);
      std::string type;
      tr(type);
      if (type != controllers_[i]->type())
        throw InputError(fmt::format("{}: controller {} is '{}', this scenario's is '{}'", path, i,
                                     type, controllers_[i]->type()));
      offset = tr.position();
      auto cs = states_[i]->clone();
      cs->read(data, offset);
      state.controllers.push_back(std::move(cs));
    }
    if (offset != data.size())
      throw InputError(fmt::format("{}: {} bytes after the state", path, data.size() - offset));
    restore(state);
  } catch (const StateFormatError& err) {
    throw InputError(fmt::format("{}: corrupt state file ({})", path, err.what()));
  }
}

}  // namespace stance
