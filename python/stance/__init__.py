"""stance: physics-based biped control on MuJoCo 2.2.2 and DART 6.12, from Python.

A thin layer over stance's C++ library: the same scenarios, loop, engines, controllers and
maths as the `stance` command.

Scenarios::

    import stance
    sim = stance.load("scenarios/biped_stand.yaml", overrides={"controllers.0.kp": 500},
                      engine="dart")
    result = sim.run()                # or sim.run(duration=2.0): 2 s more
    result.fell, result.fall_time     # summary.json's fields
    result.metrics                    # dict
    result.summary                    # the dict summary.json holds
    result.log["com_z"]               # numpy arrays keyed by log.csv's columns
    stance.run("scenarios/pd_hold.yaml").summary   # the one-liner

Stepping and state::

    sim.step(10); sim.time
    e = sim.engine                    # stance.Engine
    e.q, e.v                          # read-only numpy (MuJoCo: live views; DART: copies)
    e.set_q(q); e.set_v(v)            # writes go through setters
    e.mass_matrix(), e.solve_mass(x), e.bias_forces(), e.constraint_forces()
    e.point_jacobian("h_heel_left", p), e.com(), e.body_pose("h_pelvis"), e.contacts()
    e.inverse_dynamics(vdot), e.apply_external_force("h_spine", [50, 0, 0])
    s = sim.save(); ...; sim.restore(s)
    stance.Engine.load("dart://sample/skel/fullbody1.skel", engine="dart")

Maths: linearize_fd, linearize_fd_forces, solve_dare (P and the LQR gain K), find_lqr_setpoint,
design_lqr, lqr_state_cost.

Python controllers: any object with ``compute(engine, out)`` (and optionally ``reset(engine)``
and ``metrics()``); ``out.tau`` (dim nv) and ``out.ctrl`` (dim nu) are writable numpy views of
the step's summed outputs: add to them. Compose them with C++ controllers, either in a scenario
(``{type: python, module: my_ctrl, class: MyController, <keyword arguments>}``, resolved only
when loaded from Python) or with ``sim.add_controller(obj)``; ``sim.add_controller({"type":
"stable_pd", "kp": 400})`` adds a C++ one. Python controllers are outside the C++ registry and
its generic tests, and their own attributes are not saved, restored or branched (clones and
planner rollouts do not use them).

Viewer: stance.view(sim) opens stance's viewer on a clone of a simulation built in Python (its
Python controllers included).

Errors: stance.InputError (a ValueError) carries the CLI's one-line message with the file and
line or the parameter; stance.DivergenceError (a RuntimeError) is the CLI's exit code 3, with
``.result``.

Batch: stance.sweep, stance.tune and stance.robustness return numpy arrays and release the GIL
while C++ runs, as Simulation.run does.

Motion capture::

    clip = stance.read_bvh("walk.bvh")  # a BvhClip: joints, channel_names, frame_time,
    clip.frames                         # frames x channels (numpy), rotations, translations,
    clip.standing_height_m, clip.mean_speed_mps, clip.facing_deg, clip.warnings
    r = stance.track("walk.bvh", out="out/walk")   # `stance bvh track`: a TrackResult
    r.success, r.g_mpjpe_m, r.metrics["mocap"], r.log["root_x"], r.tracked.frames
    b = stance.track(["a.bvh", "clips/"], out="out/batch")   # many: a TrackBatchResult
    b.rows["g_mpjpe_m"], b.summary["success_rate"]           # results.csv as numpy, its summary

Every path argument takes a str or a pathlib.Path. The package ships type stubs
(__init__.pyi, py.typed) for editors and type checkers.
"""

from ._stance import (  # noqa: F401
    BvhClip,
    BvhJoint,
    ControlOutput,
    Contact,
    DareResult,
    DivergenceError,
    Engine,
    EngineState,
    InputError,
    JointInfo,
    JointType,
    LqrDesign,
    LqrSetPoint,
    RunResult,
    Simulation,
    SimulationState,
    TrackBatchResult,
    TrackResult,
    design_lqr,
    find_lqr_setpoint,
    linearize_fd,
    linearize_fd_forces,
    load,
    lqr_state_cost,
    plot_force_offset,
    read_bvh,
    robustness,
    solve_dare,
    spectral_radius,
    sweep,
    track,
    tune,
)

try:
    from ._stance import view  # noqa: F401  (built with the viewer)
except ImportError:
    pass

__all__ = [
    "BvhClip", "BvhJoint", "Controller", "ControlOutput", "Contact", "DareResult",
    "DivergenceError", "Engine", "EngineState", "InputError", "JointInfo", "JointType",
    "LqrDesign", "LqrSetPoint", "RunResult", "Simulation", "SimulationState", "TrackBatchResult",
    "TrackResult", "design_lqr", "find_lqr_setpoint", "linearize_fd", "linearize_fd_forces",
    "load", "lqr_gain", "lqr_state_cost", "plot_force_offset", "read_bvh", "robustness", "run",
    "solve_dare", "spectral_radius", "sweep", "track", "tune", "view",
]


def run(path, duration=None, **load_args):
    """Load a scenario and run it: stance.load(path, **load_args).run(duration)."""
    return load(path, **load_args).run(duration)


def lqr_gain(A, B, Q, R):
    """The LQR gain K (u = -K x) of the discrete system (A, B) with costs Q, R, via solve_dare.

    Raises RuntimeError when the DARE has no stabilising solution.
    """
    result = solve_dare(A, B, Q, R)
    if not result.success:
        raise RuntimeError("DARE: " + result.message)
    return result.K


class Controller:
    """Base class (optional) of Python controllers: override compute, and reset if needed.

    compute(engine, out) runs once per step after engine.forward(), with the GIL held; it adds
    generalised forces to out.tau (dim nv) and/or controls to out.ctrl (dim nu). The engine is
    the simulation's: read it, do not step it.
    """

    def reset(self, engine):
        """Called at the start of a run (and on sim.reset()) at the engine's state."""

    def compute(self, engine, out):
        raise NotImplementedError
