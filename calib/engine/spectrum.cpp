#include "engine/spectrum.h"

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace calib::engine {

SerialEigen::SerialEigen() : saved_(omp_get_max_threads()) { omp_set_num_threads(1); }

SerialEigen::~SerialEigen() { omp_set_num_threads(saved_); }

double largest_generalized_eigenvalue(const SparseRowMatrix &a, const Eigen::VectorXd &m_diag, int dense_limit)
{
    const Eigen::Index n = a.rows();
    if (n == 0)
        return 0.0;
    SerialEigen serial; // every caller: a product per Lanczos step is too short for a team
    const Eigen::VectorXd s = m_diag.cwiseSqrt().cwiseInverse();
    if (n <= dense_limit) {
        Eigen::MatrixXd d = s.asDiagonal() * Eigen::MatrixXd(a) * s.asDiagonal();
        Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(d, Eigen::EigenvaluesOnly);
        return es.eigenvalues().maxCoeff();
    }
    // Lanczos on the symmetric form S = M^-1/2 A M^-1/2.
    std::mt19937_64 rng(12345);
    std::normal_distribution<double> normal;
    Eigen::VectorXd v(n), v_prev = Eigen::VectorXd::Zero(n), w(n);
    for (Eigen::Index i = 0; i < n; ++i)
        v[i] = normal(rng);
    v.normalize();
    std::vector<double> alpha, beta;
    double last = 0.0;
    const int max_iter = lanczos_max_iterations;
    for (int it = 0; it < max_iter; ++it) {
        w = s.cwiseProduct(a * s.cwiseProduct(v));
        if (!beta.empty())
            w -= beta.back() * v_prev;
        const double al = v.dot(w);
        w -= al * v;
        alpha.push_back(al);
        const double be = w.norm();
        const int m = int(alpha.size());
        double top = last;
        if (m % 20 == 0 || be <= 1e-14 * std::abs(last) || it + 1 == max_iter) {
            Eigen::VectorXd diag = Eigen::Map<Eigen::VectorXd>(alpha.data(), m);
            Eigen::VectorXd sub(std::max(m - 1, 0));
            for (int i = 0; i + 1 < m; ++i)
                sub[i] = beta[std::size_t(i)];
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es;
            es.computeFromTridiagonal(diag, sub, Eigen::EigenvaluesOnly);
            top = es.eigenvalues().maxCoeff();
            if (m >= 20 && std::abs(top - last) <= 1e-11 * std::abs(top))
                return top;
            last = top;
        }
        if (be <= 1e-14 * std::abs(top))
            return top; // invariant subspace found
        beta.push_back(be);
        v_prev = v;
        v = w / be;
    }
    return last;
}

std::vector<double> lowest_generalized_eigenvalues(const SparseRowMatrix &a, const Eigen::VectorXd &m_diag, int count,
                                                   double shift)
{
    const Eigen::Index n = a.rows();
    if (count <= 0 || count > n)
        throw std::invalid_argument("lowest_generalized_eigenvalues: bad count");
    const Eigen::Index p = std::min<Eigen::Index>(n, Eigen::Index(count) + 6);
    Eigen::SparseMatrix<double> shifted = a;
    for (Eigen::Index i = 0; i < n; ++i)
        shifted.coeffRef(i, i) += shift * m_diag[i];
    Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(shifted);
    if (ldlt.info() != Eigen::Success)
        throw std::runtime_error("lowest_generalized_eigenvalues: factorisation failed");

    std::mt19937_64 rng(777);
    std::normal_distribution<double> normal;
    Eigen::MatrixXd x(n, p);
    for (Eigen::Index j = 0; j < p; ++j)
        for (Eigen::Index i = 0; i < n; ++i)
            x(i, j) = normal(rng);
    Eigen::VectorXd prev = Eigen::VectorXd::Constant(count, -1.0);
    Eigen::VectorXd lam;
    for (int it = 0; it < 500; ++it) {
        Eigen::MatrixXd y = ldlt.solve(m_diag.asDiagonal() * x);
        Eigen::MatrixXd kr = y.transpose() * (a * y);
        Eigen::MatrixXd mr = y.transpose() * m_diag.asDiagonal() * y;
        kr = 0.5 * (kr + kr.transpose()).eval();
        mr = 0.5 * (mr + mr.transpose()).eval();
        Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> es(kr, mr);
        lam = es.eigenvalues().head(count);
        x = y * es.eigenvectors();
        x.colwise().normalize();
        const double scale = std::max(std::abs(lam[count - 1]), shift);
        if ((lam - prev).cwiseAbs().maxCoeff() <= 1e-12 * scale && it > 3)
            break;
        prev = lam;
    }
    return std::vector<double>(lam.data(), lam.data() + count);
}

} // namespace calib::engine
