// MuJoCo 2.2.2's position-and-velocity half-step (mj_step1) with its two inertia stages done
// here, to the bit.
// mj_crb calls mju_dot (a library call through the PLT) for each of qM's nM entries, and
// mj_factorM calls mju_addToScl for each entry below the diagonal: on a tracked character
// (nM ~ 500) the two stages were a fifth of a rollout step, the calls a good part of it. The
// same operations in the same order, inlined, give the same qM, qLD, qLDiagInv and
// qLDiagSqrtInv bits (tests MujocoInertia.*) in fewer instructions (callgrind, the tracked walk's
// character: 40,500 -> 24,800 a step for the inertia, 37,500 -> 31,800 for its factor).
#pragma once

#include <mujoco/mujoco.h>

namespace stance {

// qM = the joint-space inertia, as mj_crb (d->crb and d->qM; reads cinert, cdof)
void composite_rigid_body_inertia(const mjModel* m, mjData* d);

// qLD, qLDiagInv, qLDiagSqrtInv = the L'DL factor of qM, as mj_factorM (a warning and the floor
// mjMINVAL on a non-positive pivot alike)
void factor_inertia(const mjModel* m, mjData* d);

// mj_step1 with the two stages above in place of MuJoCo's: the same stages in the same order
// (checks, positions, sensors, energy, velocities, the control callback). MuJoCo's stage timers
// (mjData.timer) are not kept: nothing in stance reads them.
void step_positions_and_velocities(const mjModel* m, mjData* d);

}  // namespace stance
