// Eigenvalues of the assembled plate operator: the largest (stability bound)
// and the lowest few (modal frequencies, for verification and studies).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include <vector>

namespace calib::engine {

using SparseRowMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor>;

// Limits OpenMP to this thread while an operator's stability bound is found
// (largest_generalized_eigenvalue holds one, for every caller): Lanczos'
// sparse products go through Eigen, which forks a team per product; on the
// loaded 2-core machine that made a 130 000-unknown Mindlin bound take 3 s
// instead of 0.2 s (and the Kirchhoff one 1 s instead of 0.05 s), and the
// idle team spinning between products took half the CPU of a tolerance
// study, whose every perturbed plate finds its bound.
// omp_set_num_threads changes only the calling thread's setting.
class SerialEigen {
  public:
    SerialEigen();
    ~SerialEigen();
    SerialEigen(const SerialEigen &) = delete;
    SerialEigen &operator=(const SerialEigen &) = delete;

  private:
    int saved_;
};

// Largest eigenvalue of M^-1 A (A symmetric positive semi-definite, M a
// positive diagonal). Dense symmetric solver below `dense_limit` unknowns;
// Lanczos (no re-orthogonalisation: the extreme Ritz value converges anyway)
// above, until the Ritz value is stable to ~1e-12 or after
// lanczos_max_iterations products with A.
inline constexpr int lanczos_max_iterations = 300;
double largest_generalized_eigenvalue(const SparseRowMatrix &a, const Eigen::VectorXd &m_diag, int dense_limit = 1200);

// The `count` lowest eigenvalues of A v = lambda M v, by shift-invert subspace
// iteration (sparse LDL^T of A + shift M; `shift` > 0 also handles the rigid
// modes of a free plate). Ascending; converged to ~1e-11 relative.
std::vector<double> lowest_generalized_eigenvalues(const SparseRowMatrix &a, const Eigen::VectorXd &m_diag, int count,
                                                   double shift);

} // namespace calib::engine
