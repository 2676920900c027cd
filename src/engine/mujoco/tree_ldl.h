// The LᵀDL factorisation of a kinematic-tree mass matrix (Featherstone, "Rigid Body Dynamics
// Algorithms", 6.3), stored in MuJoCo's sparse qM layout: row i starts at dof_Madr[i] with M(i,i)
// and continues with M(i,parent(i)), M(i,parent(parent(i))), ... to the root. No fill-in, so
// factor and solve cost O(nv · depth).
//
// MuJoCo 2.2.2 does not export mj_factorI, and mj_factorM overwrites mjData's own factor, which
// mj_step2's constraint solver still needs. Stable PD factors M + diag(shift) every step, so it
// gets its own buffers here.
#pragma once

#include <vector>

namespace stance {

class TreeLdl {
 public:
  TreeLdl() = default;
  // parent: dof parent index (-1 at a root), madr: each row's start; nm: total entries
  TreeLdl(const int* parent, const int* madr, int nv, int nm);

  // factors M + diag(shift); m_sparse: nm entries in the layout above, shift: nv entries
  void factor(const double* m_sparse, const double* shift);
  // x <- (M + diag(shift))⁻¹ x with the last factor; x: nv entries
  void solve(double* x) const;

  int nv() const { return nv_; }

 private:
  std::vector<int> parent_, madr_, row_length_;  // row_length_: 1 + number of ancestors
  std::vector<double> ld_;                       // L below the diagonal, D on it
  int nv_ = 0;
};

}  // namespace stance
