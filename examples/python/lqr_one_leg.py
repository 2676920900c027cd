#!/usr/bin/env python3
"""The S2 seed's notebook (MuJoCo's humanoid LQR tutorial) step by step on stance's engine.

1. inverse dynamics at the pose: the unphysical vertical root force;
2. the height sweep (+-1 mm) and its plot (matplotlib when installed, else stance's gnuplot
   helper on the library's own curve);
3. the set-point: ctrl0 = pinv(actuator_moment)^T qfrc0; ctrl0 alone falls;
4. Q from the COM and foot Jacobians and the joint costs;
5. A, B by finite differences of one step, and the DARE for K;
6. the balance: ctrl = ctrl0 - K [q (-) q0; v] in Python for 10 s.

Ends by checking its own result: the LQR holds the humanoid 10 s.

    PYTHONPATH=build/python python3 examples/python/lqr_one_leg.py [--out out/lqr_py]
"""
import argparse
import pathlib
import re
import sys

import numpy as np

import stance

SCENARIO = pathlib.Path(__file__).resolve().parents[2] / "scenarios" / "lqr_one_leg.yaml"


def humanoid():
    """the scenario's world at its pose, without its controller"""
    return stance.load(str(SCENARIO), overrides={"controllers": []})


class Lqr(stance.Controller):
    """ctrl = ctrl0 - K [q (-) q0; v]: the notebook's controller functor"""

    def __init__(self, q0, ctrl0, K):
        self.q0, self.ctrl0, self.K = q0, ctrl0, K

    def compute(self, engine, out):
        dx = np.concatenate([engine.difference_positions(self.q0, engine.q), engine.v])
        out.ctrl[:] += self.ctrl0 - self.K @ dx


class OpenLoop(stance.Controller):
    def __init__(self, ctrl0):
        self.ctrl0 = ctrl0

    def compute(self, engine, out):
        out.ctrl[:] += self.ctrl0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="out/lqr_py", help="folder for the plot")
    ap.add_argument("--duration", type=float, default=10.0, help="s of balance")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    e = humanoid().engine
    nv, nu = e.nv, e.nu
    root = e.joint("root")
    z_adr, z_dof = root.qpos_adr + 2, e.dof_index("root_pos_z")
    q_start = e.q.copy()

    # 1. inverse dynamics with qacc = 0: a large vertical force holds the model up
    qfrc = e.inverse_dynamics(np.zeros(nv))
    print(f"1. inverse dynamics at the pose: vertical root force {qfrc[z_dof]:.3f} N")

    # 2. the height sweep: the offset where the fictitious vertical force vanishes
    heights = np.linspace(-0.001, 0.001, 2001)
    u_vert = np.empty_like(heights)
    for i, h in enumerate(heights):
        q = q_start.copy()
        q[z_adr] += h
        e.set_q(q)
        u_vert[i] = e.inverse_dynamics(np.zeros(nv))[z_dof]
    height = heights[np.argmin(np.abs(u_vert))]
    weight = e.total_mass * np.linalg.norm(e.gravity)
    print(f"2. best offset {height * 1000:.3f} mm (force {u_vert.min():.1f} .. {u_vert.max():.1f} N,"
          f" weight {weight:.1f} N)")
    e.set_q(q_start)
    library = stance.find_lqr_setpoint(e)
    print(f"   the lqr controller's bracketed search: {library.height_offset_m * 1000:.4f} mm")
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5, 3))
        ax.plot(heights * 1000, u_vert, label="Vertical force")
        ax.axhline(weight, linestyle="--", label="Weight")
        ax.axvline(height * 1000, linestyle="--")
        ax.set_xlabel("Vertical offset (mm)"), ax.set_ylabel("Vertical force (N)")
        ax.legend(loc="lower right")
        fig.savefig(out / "force_offset.png", dpi=100)
        print(f"   plotted {out / 'force_offset.png'} with matplotlib")
    except ImportError:
        stance.plot_force_offset(library, str(out / "force_offset.csv"),
                                 str(out / "force_offset.png"))
        print(f"   plotted {out / 'force_offset.png'} with stance's gnuplot helper")

    # 3. the set-point and the controls that hold it
    q0 = q_start.copy()
    q0[z_adr] += height
    e.set_q(q0)
    qfrc0 = e.inverse_dynamics(np.zeros(nv))
    ctrl0 = np.linalg.pinv(e.actuator_moment()).T @ qfrc0
    held = e.actuator_moment().T @ ctrl0
    print(f"3. ctrl0 ({nu} controls); actuated joint forces match qfrc0 to "
          f"{np.abs(held - qfrc0)[6:].max():.2e} N")
    open_loop = humanoid()
    open_loop.add_controller(OpenLoop(ctrl0))
    r0 = open_loop.run(duration=3.0)
    print(f"   ctrl0 alone: fell={r0.fell}" + (f" at {r0.fall_time:.3f} s" if r0.fell else ""))

    # 4. Q: the COM over the left foot, and joint costs
    jac_com = e.subtree_com_jacobian("torso")
    jac_foot, _ = e.point_jacobian("left_foot", e.body_com("left_foot"))
    jac_diff = jac_com - jac_foot
    q_balance = jac_diff.T @ jac_diff
    names = e.dof_names
    free = np.array([e.dof_is_root(i) for i in range(nv)])
    balance = np.array([bool(re.fullmatch(r"abdomen_.*|left_(hip_.*|knee|ankle_.*)", n))
                        for n in names])
    q_joint = np.diag(np.where(free, 0.0, np.where(balance, 3.0, 0.3)))
    Q = np.zeros((2 * nv, 2 * nv))
    Q[:nv, :nv] = 1000 * q_balance + q_joint
    Q += 1e-10 * np.eye(2 * nv)
    R = np.eye(nu)
    same = np.abs(Q - stance.lqr_state_cost(e, jac_com, jac_foot)).max()
    print(f"4. Q {Q.shape}; the lqr controller's Q differs by {same:.1e}")

    # 5. linearise one step at (q0, ctrl0) and solve the DARE
    e.set_v(np.zeros(nv))
    e.set_controls(ctrl0)
    A, B = stance.linearize_fd(e, ctrl0, eps=1e-6, centered=True)
    dare = stance.solve_dare(A, B, Q, R)
    K = dare.K
    print(f"5. A {A.shape}, B {B.shape}; DARE residual {dare.relative_residual:.1e}, "
          f"closed-loop spectral radius {dare.spectral_radius:.9f}")

    # 6. the balance
    sim = humanoid()
    sim.add_controller(Lqr(q0, ctrl0, K))
    r = sim.run(duration=args.duration)
    print(f"6. LQR in Python: fell={r.fell}, {r.sim_time:.1f} s, COM height min "
          f"{r.metrics['min_com_height_m']:.3f} m")

    failures = []
    if not dare.success:
        failures.append("the DARE failed: " + dare.message)
    if same > 1e-6:
        failures.append(f"Q differs from the lqr controller's by {same}")
    if not r0.fell:
        failures.append("ctrl0 alone did not fall")
    if r.fell or r.sim_time < args.duration - 1e-9:
        failures.append(f"the LQR did not hold {args.duration:g} s (fell at {r.fall_time})")
    if failures:
        print("FAILED: " + "; ".join(failures))
        return 1
    print(f"OK: the LQR designed step by step in Python holds the humanoid {args.duration:g} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
