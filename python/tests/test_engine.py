# the engine from Python: documented shapes and dtypes, read-only views, setters, and the
# dynamics agreeing with themselves (solve against the matrix, Jacobians against velocities)
import numpy as np
import pytest

import stance
from conftest import SCENARIOS

FULLBODY1 = "dart://sample/skel/fullbody1.skel"
ENGINES = ["mujoco", "dart"]


@pytest.fixture(params=ENGINES)
def engine(request):
    return stance.Engine.load(FULLBODY1, engine=request.param)


def test_shapes_and_dtypes(engine):
    nq, nv = engine.nq, engine.nv
    # fullbody1 has a free root: MuJoCo stores its rotation as a quaternion
    assert nq == (nv + 1 if engine.name == "mujoco" else nv)
    assert engine.nu == 0
    expect = {
        "q": (engine.q, (nq,)), "v": (engine.v, (nv,)),
        "mass_matrix": (engine.mass_matrix(), (nv, nv)),
        "bias_forces": (engine.bias_forces(), (nv,)),
        "constraint_forces": (engine.constraint_forces(), (nv,)),
        "com": (engine.com(), (3,)), "com_jacobian": (engine.com_jacobian(), (3, nv)),
        "body_velocity": (engine.body_velocity(0), (6,)),
        "inverse_dynamics": (engine.inverse_dynamics(np.zeros(nv)), (nv,)),
        "solve_mass": (engine.solve_mass(np.ones(nv)), (nv,)),
        "controls": (engine.controls, (0,)),
    }
    for name, (a, shape) in expect.items():
        assert isinstance(a, np.ndarray), name
        assert a.dtype == np.float64, name
        assert a.shape == shape, name
    pos, quat = engine.body_pose("h_pelvis")
    assert pos.shape == (3,) and quat.shape == (4,)
    assert np.linalg.norm(quat) == pytest.approx(1.0)
    jp, jr = engine.point_jacobian("h_heel_left", engine.body_com("h_heel_left"))
    assert jp.shape == (3, nv) and jr.shape == (3, nv)
    assert len(engine.dof_names) == nv and len(engine.body_names) == engine.nbody
    assert len(engine.joint_names) == engine.njoint


def test_names_and_indices_round_trip(engine):
    for i, name in enumerate(engine.dof_names):
        assert engine.dof_index(name) == i
    for i, name in enumerate(engine.body_names):
        assert engine.body_index(name) == i
    j = engine.joint("j_shin_left")
    assert j.nv == 1 and j.type == stance.JointType.HINGE
    assert engine.dof_names[j.dof_adr] == "j_shin_left"
    with pytest.raises(stance.InputError, match="h_pelvis"):
        engine.body_index("h_pelvsi")


def test_views_are_read_only_and_setters_work(engine):
    q, v = engine.q, engine.v
    assert not q.flags.writeable and not v.flags.writeable
    with pytest.raises(ValueError):
        q[0] = 1.0
    shin = engine.joint("j_shin_left").qpos_adr
    q2 = engine.q.copy()
    q2[shin] = -0.7
    engine.set_q(q2)
    assert engine.q[shin] == -0.7
    v2 = np.zeros(engine.nv)
    v2[engine.dof_index("j_shin_left")] = 0.3
    engine.set_v(v2)
    np.testing.assert_array_equal(engine.v, v2)
    if engine.name == "mujoco":
        # a live view: it follows the setter
        assert q[shin] == -0.7
    with pytest.raises(stance.InputError, match=f"set_q: expected {engine.nq} values, found 3"):
        engine.set_q(np.zeros(3))


def test_mujoco_views_follow_steps_and_dart_gives_copies():
    sim = stance.load(str(SCENARIOS / "biped_stand.yaml"), engine="mujoco")
    q = sim.engine.q
    before = q.copy()
    sim.step(20)
    assert not np.array_equal(q, before)
    np.testing.assert_array_equal(q, sim.engine.q)
    dsim = stance.load(str(SCENARIOS / "biped_stand.yaml"), engine="dart")
    dq = dsim.engine.q
    before = dq.copy()
    dsim.step(20)
    np.testing.assert_array_equal(dq, before)
    assert not np.array_equal(dsim.engine.q, before)


def test_dynamics_agree_with_themselves(engine):
    rng = np.random.default_rng(3)
    engine.set_v(rng.normal(size=engine.nv) * 0.3)
    M = engine.mass_matrix()
    x = rng.normal(size=engine.nv)
    np.testing.assert_allclose(engine.solve_mass(x), np.linalg.solve(M, x), rtol=1e-9,
                               atol=1e-9 * np.abs(np.linalg.solve(M, x)).max())
    d = np.full(engine.nv, 0.04)
    np.testing.assert_allclose(engine.solve_mass_shifted(d, x), np.linalg.solve(M + np.diag(d), x),
                               rtol=1e-9, atol=1e-12)
    # J_com v is the COM velocity
    np.testing.assert_allclose(engine.com_jacobian() @ engine.v, engine.com_velocity(), atol=1e-12)
    if engine.name == "dart":
        # DART's inverse dynamics is M vdot + bias (no contact forces)
        vdot = rng.normal(size=engine.nv)
        np.testing.assert_allclose(engine.inverse_dynamics(vdot),
                                   M @ vdot + engine.bias_forces(), rtol=1e-9, atol=1e-9)


def test_external_force_moves_the_body():
    a = stance.Engine.load(str(SCENARIOS.parent / "models" / "arm3.xml"))
    b = stance.Engine.load(str(SCENARIOS.parent / "models" / "arm3.xml"))
    body = a.body_names[-1]
    a.apply_external_force(body, [0, 0, 50.0])
    a.step(), b.step()
    a.forward(), b.forward()
    # pushed up: the pushed body's velocity has a larger upward component
    assert a.body_velocity(body)[5] > b.body_velocity(body)[5] + 1e-3


def test_contacts_of_a_standing_biped():
    sim = stance.load(str(SCENARIOS / "biped_stand.yaml"), engine="mujoco")
    sim.step(500)
    e = sim.engine
    contacts = e.contacts()
    assert contacts
    feet = {e.body_index(n) for n in ["h_heel_left", "h_toe_left", "h_heel_right", "h_toe_right"]}
    assert {c.body2 if c.body1 < 0 else c.body1 for c in contacts} <= feet
    # together the contact forces carry the weight (Y-up model)
    total = sum(c.force for c in contacts)
    assert abs(total[1]) == pytest.approx(e.total_mass * 9.81, rel=0.1)
    assert e.body_touches_ground("h_heel_left")


def test_engine_state_save_restore():
    e = stance.Engine.load(FULLBODY1, engine="mujoco")
    s = e.save_state()
    for _ in range(50):
        e.step()
    q1 = e.q.copy()
    e.restore_state(s)
    assert e.time == 0
    for _ in range(50):
        e.step()
    np.testing.assert_array_equal(e.q, q1)


def test_bad_model_raises_input_error():
    with pytest.raises(stance.InputError, match="nope.xml"):
        stance.Engine.load("/nonexistent/nope.xml")


# MuJoCo's next step quietly resets a NaN state: the setters refuse one, naming the argument
def test_setters_refuse_non_finite_values(engine):
    q = engine.q.copy()
    q[3] = np.nan
    with pytest.raises(ValueError, match=r"set_q: q\[3\] is nan: positions must be finite"):
        engine.set_q(q)
    v = np.zeros(engine.nv)
    v[1] = np.inf
    with pytest.raises(ValueError, match=r"set_v: v\[1\] is inf: velocities must be finite"):
        engine.set_v(v)
    with pytest.raises(ValueError, match="set_dof_position: value is nan"):
        engine.set_dof_position("j_shin_left", float("nan"))
    for dt in (0.0, -1e-3, float("nan"), 1e-12):
        with pytest.raises(ValueError, match="timestep: "):
            engine.timestep = dt
    # nothing was taken in: the engine still steps
    assert np.isfinite(engine.q).all()
    engine.step()
    assert engine.state_is_finite()


# a state that blows up in a step is reported, with the engine's own words, not reset quietly
def test_step_reports_divergence(engine):
    v = np.zeros(engine.nv)
    v[engine.dof_index("j_shin_left")] = 1e12
    engine.set_v(v)
    with pytest.raises(stance.DivergenceError, match="simulation diverged: .*instability") as e:
        for _ in range(3):
            engine.step()
    assert e.value.result is None


# a run length no run can take is refused before it starts (it once ran for days or to the end)
def test_simulation_run_refuses_a_duration_no_run_can_take():
    sim = stance.load(str(SCENARIOS / "pd_hold.yaml"))
    for duration in (float("nan"), -1.0):
        with pytest.raises(ValueError, match="run: duration is"):
            sim.run(duration)
    with pytest.raises(ValueError, match=r"run: duration 1e\+09 s at timestep 0.001 s is 1e\+12"):
        sim.run(1e9)
    assert sim.time == 0
