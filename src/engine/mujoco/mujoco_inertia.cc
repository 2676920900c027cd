#include "engine/mujoco/mujoco_inertia.h"

#include <cmath>

// Every sum below is written in the order MuJoCo 2.2.2 computes it, and must stay so: a
// reordered sum, or a multiply-add fused into one rounding, changes the bits. CMakeLists.txt
// builds this file with -ffp-contract=off for the latter.

namespace stance {

namespace {

// mju_dot(a, b, 6): two 2-wide partial sums over the first four terms, then the last two
double dot6(const mjtNum* a, const mjtNum* b) {
  const mjtNum r0 = 0.0 + a[0] * b[0], r1 = 0.0 + a[1] * b[1];
  const mjtNum r2 = 0.0 + a[2] * b[2], r3 = 0.0 + a[3] * b[3];
  return ((r2 + r0) + (r3 + r1)) + (a[4] * b[4] + a[5] * b[5]);
}

// mju_mulInertVec: the spatial inertia (10 numbers: diagonal, off-diagonal, mass times the
// COM offset, mass) times a motion vector (rotation, translation)
void inertia_times_motion(mjtNum res[6], const mjtNum i[10], const mjtNum v[6]) {
  res[0] = i[0] * v[0] + i[3] * v[1] + i[4] * v[2] - i[8] * v[4] + i[7] * v[5];
  res[1] = i[3] * v[0] + i[1] * v[1] + i[5] * v[2] + i[8] * v[3] - i[6] * v[5];
  res[2] = i[4] * v[0] + i[5] * v[1] + i[2] * v[2] - i[7] * v[3] + i[6] * v[4];
  res[3] = i[8] * v[1] - i[7] * v[2] + i[9] * v[3];
  res[4] = i[6] * v[2] - i[8] * v[0] + i[9] * v[4];
  res[5] = i[7] * v[0] - i[6] * v[1] + i[9] * v[5];
}

}  // namespace

void composite_rigid_body_inertia(const mjModel* m, mjData* d) {
  // each body's inertia plus its subtree's, leaves first (the world body takes none)
  mjtNum* crb = d->crb;
  mju_copy(crb, d->cinert, 10 * m->nbody);
  for (int b = m->nbody - 1; b > 0; --b) {
    const int parent = m->body_parentid[b];
    if (parent > 0)
      for (int k = 0; k < 10; ++k) crb[10 * parent + k] += crb[10 * b + k];
  }
  // row i of qM: the armature, then cdof_j' crb cdof_i for i and each ancestor j, in qM's
  // sparse layout (the diagonal first); a simple dof keeps its constant M0
  mju_zero(d->qM, m->nM);
  for (int i = m->nv - 1; i >= 0; --i) {
    int adr = m->dof_Madr[i];
    if (m->dof_simplenum[i]) {
      d->qM[adr] = m->dof_M0[i];
      continue;
    }
    d->qM[adr] = m->dof_armature[i];
    mjtNum force[6];
    inertia_times_motion(force, crb + 10 * m->dof_bodyid[i], d->cdof + 6 * i);
    for (int j = i; j >= 0; j = m->dof_parentid[j], ++adr)
      d->qM[adr] += dot6(d->cdof + 6 * j, force);
  }
}

void factor_inertia(const mjModel* m, mjData* d) {
  mjtNum* ld = d->qLD;
  const int* madr = m->dof_Madr;
  mju_copy(ld, d->qM, m->nM);
  // from the leaves up: eliminate row k from each ancestor's row (which runs to the root)
  for (int k = m->nv - 1; k >= 0; --k) {
    const int adr_kk = madr[k];
    if (ld[adr_kk] < mjMINVAL) {
      mj_warning(d, mjWARN_INERTIA, k);
      ld[adr_kk] = mjMINVAL;
    }
    if (m->dof_simplenum[k]) continue;
    int adr_ki = adr_kk + 1;
    for (int i = m->dof_parentid[k]; i >= 0; i = m->dof_parentid[i], ++adr_ki) {
      const mjtNum lki = ld[adr_ki] / ld[adr_kk];
      const mjtNum minus_lki = -lki;
      const int row_length = madr[i + 1] - madr[i];  // i < k, so row i + 1 exists
      mjtNum* row_i = ld + madr[i];
      const mjtNum* row_k = ld + adr_ki;
      for (int t = 0; t < row_length; ++t) row_i[t] = row_k[t] * minus_lki + row_i[t];
      ld[adr_ki] = lki;
    }
  }
  for (int i = 0; i < m->nv; ++i) {
    const mjtNum pivot = ld[madr[i]];
    d->qLDiagInv[i] = 1.0 / pivot;
    d->qLDiagSqrtInv[i] = 1.0 / std::sqrt(pivot);
  }
}

void step_positions_and_velocities(const mjModel* m, mjData* d) {
  mj_checkPos(m, d);
  mj_checkVel(m, d);
  // mj_fwdPosition, stage by stage
  mj_kinematics(m, d);
  mj_comPos(m, d);
  mj_camlight(m, d);
  mj_tendon(m, d);
  composite_rigid_body_inertia(m, d);
  factor_inertia(m, d);
  mj_collision(m, d);
  mj_makeConstraint(m, d);
  mj_transmission(m, d);
  mj_projectConstraint(m, d);
  // the rest of mj_step1
  mj_sensorPos(m, d);
  mj_energyPos(m, d);
  mj_fwdVelocity(m, d);
  mj_sensorVel(m, d);
  mj_energyVel(m, d);
  if (mjcb_control) mjcb_control(m, d);
}

}  // namespace stance
