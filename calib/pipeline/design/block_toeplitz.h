// The inverse filter's normal matrix (inverse_filter.h) by its structure:
// over the whole support it is symmetric block Toeplitz, so it is applied
// by FFT without being formed (for the Lanczos iteration and the residuals)
// and solved by block Levinson, checked against the residual a backward-
// stable solve leaves. Neither Eigen nor Spectra has a Toeplitz solver; the
// dense Cholesky stays as the fallback (inverse_filter.cpp).
#pragma once
#include "pipeline/signal/real_fft.h"

#include <Eigen/Dense>

#include <complex>
#include <cstddef>
#include <vector>

namespace calib::pipeline {

// Channel pairs (c <= d) in order, each with its 2 J - 1 lags: the layout of
// the summed correlations R (inverse_filter.cpp).
inline std::size_t lag_count(std::size_t J) { return 2 * J - 1; }

// The normal matrix as its lags, G[(c,j),(d,jj)] = a_cd[j - jj], |j - jj| < J,
// applied by FFT (the C^2 lag sequences' spectra, 2 C transforms a product;
// `fft` of at least 3 J - 2 points, so the linear convolution fits): what the
// Lanczos iteration and the residuals need without forming G.
class ToeplitzOperator {
  public:
    using Scalar = double; // for Spectra
    // R as summed_correlations gives it: the data part.
    ToeplitzOperator(const Eigen::VectorXd &R, std::size_t C, std::size_t J, RealFft &fft);
    // Adds beta times the penalty's lags (penalty_lags) to every channel's own.
    void regularise(double beta, const std::vector<double> &pen);

    Eigen::Index rows() const { return Eigen::Index(C_ * J_); }
    Eigen::Index cols() const { return rows(); }
    void perform_op(const double *x, double *y) const; // y = G x
    // a_cd[k], |k| < J.
    double lag(std::size_t c, std::size_t d, long k) const { return a_(Eigen::Index(c * C_ + d), k + long(J_) - 1); }
    // The largest row sum of |G| (its infinity norm).
    double norm_inf() const;

  private:
    void transform(std::size_t cd);

    std::size_t C_, J_;
    RealFft &fft_;
    Eigen::MatrixXd a_;                                                     // [c C + d][k + J - 1]
    Eigen::Matrix<std::complex<double>, Eigen::Dynamic, Eigen::Dynamic> A_; // [c C + d][bin]: their spectra
};

// The inverse of the regularised normal matrix by its block Toeplitz
// structure. Reordered by time first, G is symmetric block Toeplitz: block
// (j, jj) is the C x C matrix M_{j - jj}, M_k[c][d] = a_cd[k], M_{-k} = M_k^T.
// Block Levinson (Whittle; Wiggins & Robinson) grows the forward and backward
// predictors F^k, B^k of the leading k + 1 blocks T_k,
//   T_k F^k = [E_f^k; 0 ...],  T_k B^k = [... 0; E_b^k],  F^k_0 = B^k_k = I,
// and the B^k as columns make the unit upper triangular U with
// G^{-1} = U diag(E_b^k)^{-1} U^T (U^T G U is lower triangular and symmetric,
// so block diagonal): 2 C^3 J^2 products against the (C J)^3 / 3 of a
// Cholesky factor, 1/20 for 8 exciters and J = 172. The recursion's block
// products run as kernels compiled per ISA (levinson_kernels.h).
class BlockLevinson {
  public:
    BlockLevinson(std::size_t C, std::size_t J);
    // Factors G (its lags); false when an E^k is not positive definite.
    bool factor(const ToeplitzOperator &G);
    // G^{-1} r in G's ordering (channel first).
    Eigen::VectorXd solve(const Eigen::VectorXd &r) const;

  private:
    std::size_t C_, J_;
    Eigen::MatrixXd U_;                          // time first; only its strict upper triangle is read
    std::vector<Eigen::LLT<Eigen::MatrixXd>> E_; // E_b^k
    Eigen::MatrixXd row_, top_, F_, B_, f_;      // the factorisation's room, kept for the next one
};

// G x = b by BlockLevinson and iterative refinement until the residual is as
// small as a backward-stable solve leaves it (LAPACK's dsposv criterion),
// |r| <= |x| |G| eps sqrt(n) (infinity norms, eps double's): the result is
// then as accurate as the Cholesky solve's. False when Levinson breaks down
// or does not get there in a few passes, and the caller factors G.
bool toeplitz_solve(const ToeplitzOperator &G, BlockLevinson &lev, const Eigen::VectorXd &b, Eigen::VectorXd &x);

} // namespace calib::pipeline
