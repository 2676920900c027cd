#!/usr/bin/env python3
"""The S0 seed's lessons (DART's dartpy biped tutorial) written against stance.

1. stable PD (SPD) and the ankle strategy in Python with numpy, as the seed writes them, on
   stance's fullbody1 on MuJoCo and on DART. MuJoCo's free joint stores a quaternion
   (nq = nv + 1), so position errors use the engine's difference and integration instead of
   the seed's q + dq dt - q_d;
2. pushes on the spine;
3. the same scenario with stance's C++ controllers (stable_pd + ankle_strategy);
4. the per-step time of both.

Ends by checking its own result: the biped stands in every run.

    PYTHONPATH=build/python python3 examples/python/biped_tutorial.py [--duration 5]
"""
import argparse
import pathlib
import sys
import time

import numpy as np

import stance

SCENARIO = pathlib.Path(__file__).resolve().parents[2] / "scenarios" / "biped_stand.yaml"


class SeedSpd(stance.Controller):
    """The seed's customPreStep: SPD (Kp 400, Kd 40) and the ankle bands.

    tau = p + d - Kd ddq dt, with (M + Kd dt) ddq = -C + p + d + tau_c, p = -Kp (q + dq dt - q_d),
    d = -Kd dq; the root dofs are left free. The scenario's torque_scale (0.8) multiplies the
    sum, as the seed's final `tau * 0.8`. The gains are diagonal, so they are kept as vectors,
    and the seed's dense inverse of M + Kd dt is the engine's own factorisation
    (solve_mass_shifted: MuJoCo's sparse LDL), which is what makes the loop fast.
    """

    def __init__(self, kp=400.0, kd=40.0):
        self.kp, self.kd = kp, kd

    def reset(self, engine):
        root = np.array([engine.dof_is_root(i) for i in range(engine.nv)])
        self.Kp = np.where(root, 0.0, self.kp)  # the diagonals of the seed's Kp and Kd
        self.Kd = np.where(root, 0.0, self.kd)
        self.root = root
        self.q_d = engine.q.copy()
        self.heel = engine.body_index("h_heel_left")
        self.lf = [engine.dof_index("j_heel_left_1"), engine.dof_index("j_toe_left")]
        self.rf = [engine.dof_index("j_heel_right_1"), engine.dof_index("j_toe_right")]
        self.pre = 0.0

    def compute(self, engine, out):
        dt = engine.timestep
        q, dq = engine.q, engine.v
        # q + dq dt - q_d on the configuration manifold (a quaternion root on MuJoCo)
        err = engine.difference_positions(self.q_d, engine.integrate_positions(q, dq, dt))
        p = -self.Kp * err
        d = -self.Kd * dq
        rhs = -engine.bias_forces() + p + d + engine.constraint_forces()
        ddq = engine.solve_mass_shifted(self.Kd * dt, rhs)  # (M + Kd dt)^-1 rhs
        tau = p + d + (-self.Kd * ddq) * dt
        # the ankle strategy: COM ahead of or behind the left heel's centre of pressure
        com = engine.com()
        pos, _ = engine.body_pose(self.heel)
        cop = pos + engine.body_rotation(self.heel) @ np.array([0.05, 0.0, 0.0])
        off = com[0] - cop[0]
        if 0.0 < off < 0.1:
            k1, k2, kd = 200.0, 100.0, 10.0
        elif -0.2 < off < -0.05:
            k1, k2, kd = 2000.0, 100.0, 100.0
        else:
            k1 = k2 = kd = 0.0
        for f in (self.lf, self.rf):
            tau[f[0]] += -k1 * off + kd * (self.pre - off)
            tau[f[1]] += -k2 * off + kd * (self.pre - off)
        self.pre = off
        tau[self.root] = 0.0
        out.tau[:] += tau


def python_controlled(engine, duration, pushes=()):
    """biped_stand's world with the seed's controller in Python instead of the C++ ones"""
    sim = stance.load(str(SCENARIO), engine=engine, duration=duration,
                      overrides={"controllers": []}, pushes=list(pushes))
    sim.add_controller(SeedSpd())
    return sim


def cpp_controlled(engine, duration, pushes=()):
    return stance.load(str(SCENARIO), engine=engine, duration=duration, pushes=list(pushes))


def timed_run(sim):
    t0 = time.perf_counter()
    r = sim.run()
    return r, (time.perf_counter() - t0) / max(r.steps, 1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=5.0, help="s per run")
    ap.add_argument("--engines", default="mujoco,dart")
    args = ap.parse_args()
    failures = []
    for engine in args.engines.split(","):
        print(f"== {engine}")
        # lessons 1 and 4: SPD + ankle strategy in Python, then stance's C++ controllers
        rp, per_py = timed_run(python_controlled(engine, args.duration))
        rc, per_cpp = timed_run(cpp_controlled(engine, args.duration))
        print(f"  Python SPD + ankle: fell={rp.fell}  COM height min "
              f"{rp.metrics['min_com_height_m']:.3f} m  {per_py * 1e6:.1f} us/step")
        print(f"  C++ stable_pd + ankle_strategy: fell={rc.fell}  COM height min "
              f"{rc.metrics['min_com_height_m']:.3f} m  {per_cpp * 1e6:.1f} us/step")
        print(f"  per step: Python controller {per_py / per_cpp:.2f}x the C++ controllers' run")
        # lesson 2: a push on the spine at 2 s, 0.1 s long, forward then backward
        for force in (40.0, -40.0):
            push = f"h_spine,{force},0,0,2.0,0.1"
            r = python_controlled(engine, args.duration, [push]).run()
            print(f"  pushed {force:+.0f} N (Python controller): fell={r.fell} "
                  f"pushes survived {r.metrics['pushes_survived']}/{r.metrics['pushes_applied']}")
            if r.fell:
                failures.append(f"{engine}: fell under a {force:+.0f} N push")
        for label, r in (("Python", rp), ("C++", rc)):
            if r.fell:
                failures.append(f"{engine}: the {label}-controlled biped fell at {r.fall_time} s")
    if failures:
        print("FAILED: " + "; ".join(failures))
        return 1
    print(f"OK: the biped stands {args.duration:g} s on every engine, pushed or not, "
          "under the Python and the C++ controllers")
    return 0


if __name__ == "__main__":
    sys.exit(main())
