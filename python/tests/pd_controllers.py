# Python controllers the tests load by `type: python, module: pd_controllers, class: ...`
import numpy as np

import stance


class JointPd(stance.Controller):
    """plain joint PD on the named hinge dofs, as the C++ `pd` type computes it:
    tau = -kp (q - target) - kd v"""

    def __init__(self, kp, kd, target):
        self.kp, self.kd, self.target = kp, kd, target

    def reset(self, engine):
        self.dofs = np.array([engine.dof_index(n) for n in self.target])
        self.adr = np.array([engine.joint(engine.dof_joint(d)).qpos_adr for d in self.dofs])
        self.q_target = np.array(list(self.target.values()), dtype=float)

    def compute(self, engine, out):
        err = engine.q[self.adr] + engine.v[self.dofs] * 0.0 - self.q_target
        p = -self.kp * err
        p -= self.kd * engine.v[self.dofs]
        out.tau[self.dofs] += p


class Failing(stance.Controller):
    def compute(self, engine, out):
        raise ZeroDivisionError("this controller fails at t=%g" % engine.time)
