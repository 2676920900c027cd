#include "engine/mujoco/tree_ldl.h"

#include <algorithm>
#include <cstring>

namespace stance {

TreeLdl::TreeLdl(const int* parent, const int* madr, int nv, int nm)
    : parent_(parent, parent + nv), madr_(madr, madr + nv), row_length_(nv), ld_(nm), nv_(nv) {
  // parents precede their children, so one forward pass gives every depth
  for (int i = 0; i < nv; ++i) row_length_[i] = parent[i] < 0 ? 1 : row_length_[parent[i]] + 1;
}

void TreeLdl::factor(const double* m_sparse, const double* shift) {
  std::memcpy(ld_.data(), m_sparse, sizeof(double) * ld_.size());
  for (int i = 0; i < nv_; ++i) ld_[madr_[i]] += shift[i];
  // from the leaves up: eliminate row k from each of its ancestors' rows
  for (int k = nv_ - 1; k >= 0; --k) {
    const double inv_dkk = 1.0 / ld_[madr_[k]];
    int adr_ki = madr_[k] + 1;
    for (int i = parent_[k]; i >= 0; i = parent_[i], ++adr_ki) {
      const double lki = ld_[adr_ki] * inv_dkk;
      // H(i, j) -= H(k, j) lki for i and each ancestor j of i; both rows run up to the root
      double* row_i = &ld_[madr_[i]];
      const double* row_k = &ld_[adr_ki];
      for (int t = 0; t < row_length_[i]; ++t) row_i[t] -= row_k[t] * lki;
      ld_[adr_ki] = lki;
    }
  }
}

void TreeLdl::solve(double* x) const {
  // Lᵀ y = x, leaves first
  for (int i = nv_ - 1; i >= 0; --i) {
    int adr = madr_[i] + 1;
    for (int j = parent_[i]; j >= 0; j = parent_[j], ++adr) x[j] -= ld_[adr] * x[i];
  }
  for (int i = 0; i < nv_; ++i) x[i] /= ld_[madr_[i]];
  // L x = z, root first
  for (int i = 0; i < nv_; ++i) {
    int adr = madr_[i] + 1;
    for (int j = parent_[i]; j >= 0; j = parent_[j], ++adr) x[i] -= ld_[adr] * x[j];
  }
}

}  // namespace stance
