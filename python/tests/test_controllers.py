# Python controllers in stance's loop: a numpy SPD against stable_pd's torques, a Python PD
# against the C++ pd's run, composition with C++ controllers, errors, and the LQR from Python
import csv

import numpy as np
import pytest

import stance
from conftest import SCENARIOS, read_summary, run_cli, without_wall_clock

ARM = SCENARIOS.parent / "models" / "arm3.xml"


class SpdProbe:
    """stable PD written in numpy as the S0 seed writes it (on the engine's position algebra);
    added after a C++ stable_pd, it compares its torques with the ones in out.tau"""

    def __init__(self, kp, kd):
        self.kp, self.kd = kp, kd
        self.worst = 0.0
        self.steps = 0

    def reset(self, engine):
        root = np.array([engine.dof_is_root(i) for i in range(engine.nv)])
        self.kp_vec = np.where(root, 0.0, self.kp)
        self.kd_vec = np.where(root, 0.0, self.kd)
        self.q_target = engine.q.copy()

    def compute(self, engine, out):
        dt = engine.timestep
        q, v = engine.q, engine.v
        err = engine.difference_positions(self.q_target, engine.integrate_positions(q, v, dt))
        p = -self.kp_vec * err
        d = -self.kd_vec * v
        rhs = p + d - engine.bias_forces() + engine.constraint_forces()
        vdot = engine.solve_mass_shifted(self.kd_vec * dt, rhs)
        tau = p + d - self.kd_vec * dt * vdot
        scale = np.abs(tau).max()
        self.worst = max(self.worst, np.abs(out.tau - tau).max() / scale)
        self.steps += 1


@pytest.mark.parametrize("engine", ["mujoco", "dart"])
def test_python_spd_reproduces_stable_pd(tmp, engine):
    # biped_stand with stable_pd alone: the probe sees its torques alone in out.tau
    head, tail = (SCENARIOS / "biped_stand.yaml").read_text().split("controllers:")
    y = tmp / "spd.yaml"
    y.write_text(head + "controllers:\n  - {type: stable_pd, kp: 400, kd: 40}\nfall:" +
                 tail.split("fall:")[1])
    sim = stance.load(str(y), engine=engine, duration=1)
    probe = SpdProbe(400, 40)
    sim.add_controller(probe)
    r = sim.run()
    assert not r.fell
    assert probe.steps == 1000 == r.steps
    assert probe.worst <= 1e-9


def pd_yaml(tmp, controller):
    y = tmp / "arm.yaml"
    y.write_text((SCENARIOS / "pd_arm.yaml").read_text().split("controllers:")[0].replace(
        "../models/arm3.xml", str(ARM)) + "controllers:\n" + controller +
        "fall:\n  enabled: false\n")
    return y


def test_python_pd_from_yaml_equals_the_cpp_pd_run(tmp):
    cpp = stance.run(str(SCENARIOS / "pd_arm.yaml"))
    y = pd_yaml(tmp, "  - {type: python, module: pd_controllers, class: JointPd, kp: 60, kd: 3,\n"
                     "     target: {shoulder: 0.0, elbow: 0.0, wrist: 0.0}}\n")
    py = stance.run(str(y))
    assert py.summary["steps"] == cpp.summary["steps"] == 5000
    # the same metrics, less the C++ pd's own tracking error
    cpp_metrics = without_wall_clock(cpp.metrics)
    assert cpp_metrics.pop("pd_rms_error_rad") > 0
    assert without_wall_clock(py.metrics) == cpp_metrics
    for name in ["com_x", "com_y", "com_z", "root_x", "root_z"]:
        np.testing.assert_array_equal(py.log[name], cpp.log[name])


def test_python_and_cpp_controllers_compose(tmp):
    # half the gains in Python (from the YAML) plus half in C++ (added) is the whole C++ pd
    whole = stance.load(str(SCENARIOS / "pd_arm.yaml"), duration=2)
    rw = whole.run()
    y = pd_yaml(tmp, "  - {type: python, module: pd_controllers, class: JointPd, kp: 30, kd: 1.5,"
                     "\n     target: {shoulder: 0.0, elbow: 0.0, wrist: 0.0}}\n")
    half = stance.load(str(y), duration=2)
    half.add_controller({"type": "pd", "kp": 30, "kd": 1.5,
                         "target": {"shoulder": 0.0, "elbow": 0.0, "wrist": 0.0}})
    assert half.controller_types == ["python", "pd"]
    rh = half.run()
    np.testing.assert_allclose(half.engine.q, whole.engine.q, atol=1e-9)
    assert rh.metrics["torque_rms"] == pytest.approx(rw.metrics["torque_rms"], rel=1e-9)


def test_python_controller_errors(tmp):
    y = pd_yaml(tmp, "  - {type: python, module: pd_controllers, class: Failing}\n")
    sim = stance.load(str(y))
    with pytest.raises(ZeroDivisionError, match="fails at t=0"):
        sim.run()
    y = pd_yaml(tmp, "  - {type: python, module: no_such_module, class: X}\n")
    line = y.read_text().splitlines().index("  - {type: python, module: no_such_module, class: X}")
    with pytest.raises(stance.InputError) as e:
        stance.load(str(y))
    assert str(e.value) == (f"{y}:{line + 1}: controllers[0]: cannot import python module "
                            "'no_such_module': ModuleNotFoundError: No module named "
                            "'no_such_module'")
    y = pd_yaml(tmp, "  - {type: python, module: pd_controllers, class: Nope}\n")
    with pytest.raises(stance.InputError, match="module 'pd_controllers' has no class 'Nope'"):
        stance.load(str(y))
    y = pd_yaml(tmp, "  - {type: python, module: pd_controllers, class: JointPd, kq: 1}\n")
    with pytest.raises(TypeError, match="kq"):
        stance.load(str(y))


def lqr_engine():
    """humanoid.xml at lqr_one_leg's start, without its controller"""
    return stance.load(str(SCENARIOS / "lqr_one_leg.yaml"), overrides={"controllers": []}).engine


def test_lqr_gain_from_python_equals_k_csv(tmp):
    rc, _, err = run_cli("run", SCENARIOS / "lqr_one_leg.yaml", "--duration", 0.01, "--quiet",
                         "--set", "controllers.0.force_plot=false", "--out", tmp)
    assert rc == 0, err
    with open(tmp / "K.csv") as f:
        rows = list(csv.reader(f))
    K_csv = np.array([r[1:] for r in rows[1:]], dtype=float)
    design = stance.design_lqr(lqr_engine(), root_body="torso", stance_foot="left_foot")
    assert design.K.shape == K_csv.shape == (21, 54)
    assert [r[0] for r in rows[1:]] == design.actuator_names
    np.testing.assert_allclose(design.K, K_csv, rtol=0, atol=1e-9 * np.abs(K_csv).max())
    # the same gain through the maths alone
    np.testing.assert_allclose(stance.lqr_gain(design.A, design.B, design.Q, design.R),
                               design.K, rtol=0, atol=1e-9 * np.abs(K_csv).max())


class PyLqr:
    """the lqr controller's per-step law in numpy: ctrl = ctrl0 - K [q (-) q0; v]"""

    def __init__(self, design):
        self.d = design

    def compute(self, engine, out):
        sp = self.d.setpoint
        x = np.concatenate([engine.difference_positions(sp.q0, engine.q), engine.v])
        out.ctrl[:] += sp.ctrl0 - self.d.K @ x


def test_python_lqr_balances_as_the_cpp_lqr(tmp):
    cpp = stance.load(str(SCENARIOS / "lqr_one_leg.yaml"), duration=3,
                      overrides={"controllers.0.force_plot": False})
    rc = cpp.run()
    py = stance.load(str(SCENARIOS / "lqr_one_leg.yaml"), duration=3,
                     overrides={"controllers": []})
    design = stance.design_lqr(py.engine)
    py.add_controller(PyLqr(design))
    rp = py.run()
    assert not rp.fell and not rc.fell
    np.testing.assert_allclose(rp.log["com_x"], rc.log["com_x"], atol=1e-6)
    np.testing.assert_allclose(rp.log["com_z"], rc.log["com_z"], atol=1e-6)
