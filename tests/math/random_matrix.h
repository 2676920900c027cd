// Seeded gaussian matrices for the DARE tests (ours and the SLICOT cross-check).
#pragma once

#include <Eigen/Core>
#include <random>

namespace stance::test {

inline Eigen::MatrixXd random_matrix(std::mt19937& rng, int rows, int cols) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd M(rows, cols);
  for (int j = 0; j < cols; ++j)
    for (int i = 0; i < rows; ++i) M(i, j) = normal(rng);
  return M;
}

}  // namespace stance::test
