#include "engine/modes.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <Spectra/SymEigsShiftSolver.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::engine {

const char *parity_name(Parity p)
{
    switch (p) {
    case Parity::symmetric:
        return "sym";
    case Parity::antisymmetric:
        return "anti";
    case Parity::mixed:
        return "mixed";
    case Parity::not_applicable:
        return "-";
    }
    return "?";
}

namespace {

// Spectra's shift-solve operation for A = M^-1/2 K M^-1/2:
//   (A - sigma I)^-1 x = M^1/2 (K - sigma M)^-1 M^1/2 x,
// one sparse Cholesky factor (minimum-degree ordering) per shift.
class MassScaledShiftSolve {
  public:
    using Scalar = double;

    MassScaledShiftSolve(const PlateOperator::SparseMatrix &k, const Eigen::VectorXd &m)
        : k_(k), m_(m), sqrt_m_(m.cwiseSqrt())
    {}
    Eigen::Index rows() const { return k_.rows(); }
    Eigen::Index cols() const { return k_.cols(); }

    void set_shift(double sigma)
    {
        const Eigen::Index n = k_.rows();
        Eigen::SparseMatrix<double> shift(n, n);
        std::vector<Eigen::Triplet<double>> diag;
        diag.reserve(std::size_t(n));
        for (Eigen::Index i = 0; i < n; ++i)
            diag.emplace_back(i, i, -sigma * m_[i]);
        shift.setFromTriplets(diag.begin(), diag.end());
        const Eigen::SparseMatrix<double> shifted = Eigen::SparseMatrix<double>(k_) + shift;
        llt_.compute(shifted);
        if (llt_.info() != Eigen::Success)
            throw std::runtime_error("modes: the Cholesky factorisation of K - sigma M failed (K not positive "
                                     "semi-definite?)");
    }

    void perform_op(const double *x_in, double *y_out) const
    {
        const Eigen::Index n = k_.rows();
        Eigen::Map<const Eigen::VectorXd> x(x_in, n);
        Eigen::Map<Eigen::VectorXd> y(y_out, n);
        y = sqrt_m_.cwiseProduct(llt_.solve(sqrt_m_.cwiseProduct(x)).eval());
    }

  private:
    const PlateOperator::SparseMatrix &k_;
    const Eigen::VectorXd &m_;
    Eigen::VectorXd sqrt_m_;
    Eigen::SimplicialLLT<Eigen::SparseMatrix<double>, Eigen::Lower> llt_;
};

// The unknown each unknown is mirrored to (x -> Lx - x or y -> Ly - y), or
// empty when the two mirrored edges differ (no symmetry).
std::vector<Eigen::Index> mirror_of(const PlateOperator &op, bool along_x)
{
    const Edges &e = op.params().edges;
    if (along_x ? e.left != e.right : e.bottom != e.top)
        return {};
    const Grid &g = op.grid();
    std::vector<Eigen::Index> out(op.unknown_count());
    for (std::size_t u = 0; u < op.unknown_count(); ++u) {
        const std::size_t node = op.node_of()[u];
        const int i = int(node % std::size_t(g.nx + 1)), j = int(node / std::size_t(g.nx + 1));
        const std::ptrdiff_t m = op.unknown_of()[along_x ? g.node(g.nx - i, j) : g.node(i, g.ny - j)];
        if (m < 0)
            return {}; // cannot happen with equal edge kinds; no symmetry claimed if it does
        out[u] = Eigen::Index(m);
    }
    return out;
}

Eigen::VectorXd mirrored(const Eigen::Ref<const Eigen::VectorXd> &v, const std::vector<Eigen::Index> &mirror)
{
    Eigen::VectorXd r(v.size());
    for (Eigen::Index u = 0; u < v.size(); ++u)
        r[u] = v[mirror[std::size_t(u)]];
    return r;
}

// v^T M R v of an M-normalized vector is +-1 for a (anti)symmetric shape;
// the Lanczos vectors are accurate to well under 1e-4 of that.
Parity classify(const Eigen::Ref<const Eigen::VectorXd> &v, const Eigen::VectorXd &m,
                const std::vector<Eigen::Index> &mirror)
{
    if (mirror.empty())
        return Parity::not_applicable;
    const double p = v.dot(m.cwiseProduct(mirrored(v, mirror))) / v.dot(m.cwiseProduct(v));
    if (p > 1 - 1e-4)
        return Parity::symmetric;
    if (p < -(1 - 1e-4))
        return Parity::antisymmetric;
    return Parity::mixed;
}

} // namespace

PlateModes lowest_modes(const PlateOperator &op, int count)
{
    const Eigen::Index n = Eigen::Index(op.unknown_count());
    if (count < 1 || Eigen::Index(count) >= n) {
        char b[160];
        std::snprintf(b, sizeof b,
                      "modes: the count must be at least 1 and below the %ld unknowns of the grid (got %d)", long(n),
                      count);
        throw std::invalid_argument(b);
    }
    const PlateParams &pp = op.params();
    const double lx = op.grid().length_x_m(), ly = op.grid().length_y_m();
    // Half the simply supported fundamental omega_11^2: the scale of the
    // lowest eigenvalues (good Lanczos ratios), and safely below a free
    // plate's rigid-body zeros.
    const double pi2 = std::numbers::pi * std::numbers::pi;
    const double omega11 = op.kappa() * pi2 * (1 / (lx * lx) + 1 / (ly * ly));
    const double sigma = -0.5 * omega11 * omega11;

    MassScaledShiftSolve solve(op.stiffness(), op.mass());
    const Eigen::Index ncv = std::min<Eigen::Index>(n, std::max<Eigen::Index>(2 * count + 1, count + 20));
    Spectra::SymEigsShiftSolver<MassScaledShiftSolve> eigs(solve, count, ncv, sigma);
    eigs.init();
    eigs.compute(Spectra::SortRule::LargestMagn, 1000, 1e-10, Spectra::SortRule::SmallestAlge);
    if (eigs.info() != Spectra::CompInfo::Successful) {
        char b[160];
        std::snprintf(b, sizeof b, "modes: Lanczos did not converge to %d modes in %ld restarts (%ld unknowns)", count,
                      long(eigs.num_iterations()), long(n));
        throw std::runtime_error(b);
    }

    PlateModes out;
    out.iterations = long(eigs.num_iterations());
    out.operations = long(eigs.num_operations());
    const Eigen::VectorXd lambda = eigs.eigenvalues();
    const Eigen::VectorXd inv_sqrt_m = op.mass().cwiseSqrt().cwiseInverse();
    out.shapes = inv_sqrt_m.asDiagonal() * eigs.eigenvectors();
    const Eigen::VectorXd &m = op.mass();
    const std::vector<Eigen::Index> mx = mirror_of(op, true), my = mirror_of(op, false);

    // Degenerate groups (equal to round-off: a square's (m, n) and (n, m),
    // the free plate's rigid-body modes): any basis of the group is an
    // answer, so pick the one that diagonalises the mirrors (Rx + 2 Ry has
    // the distinct eigenvalues +-1 +-2 on the four parity classes; both
    // commute with K and M when the edges are mirror-symmetric).
    std::vector<double> eig(lambda.data(), lambda.data() + count);
    const double tol = 1e-8 * std::max(std::abs(eig.back()), -sigma);
    for (int a = 0; a < count;) {
        int b = a + 1;
        while (b < count && eig[std::size_t(b)] - eig[std::size_t(b - 1)] <= tol)
            ++b;
        if (b - a > 1 && (!mx.empty() || !my.empty())) {
            auto group = out.shapes.middleCols(a, b - a);
            Eigen::MatrixXd rv = Eigen::MatrixXd::Zero(n, b - a);
            for (int c = 0; c < b - a; ++c) {
                if (!mx.empty())
                    rv.col(c) += mirrored(group.col(c), mx);
                if (!my.empty())
                    rv.col(c) += 2 * mirrored(group.col(c), my);
            }
            Eigen::MatrixXd cm = group.transpose() * m.asDiagonal() * rv;
            cm = 0.5 * (cm + cm.transpose()).eval();
            Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(cm);
            group = (group * es.eigenvectors()).eval();
            for (int c = a; c < b; ++c) {
                const auto v = out.shapes.col(c);
                eig[std::size_t(c)] = v.dot(op.stiffness() * v) / v.dot(m.cwiseProduct(v));
            }
        }
        a = b;
    }

    for (int c = 0; c < count; ++c) {
        auto v = out.shapes.col(c);
        Eigen::Index at = 0;
        v.cwiseAbs().maxCoeff(&at);
        if (v[at] < 0)
            v = -v;
        out.eigenvalue_rad2_s2.push_back(eig[std::size_t(c)]);
        out.frequency_hz.push_back(std::sqrt(std::max(eig[std::size_t(c)], 0.0)) / (2 * std::numbers::pi));
        const double vmv = v.dot(m.cwiseProduct(v));
        out.decay_rate_1_s.push_back(
            pp.loss.active() ? pp.loss.sigma0 + pp.loss.sigma1 * v.dot(op.dirichlet() * v) / vmv : 0.0);
        out.parity_x.push_back(classify(v, m, mx));
        out.parity_y.push_back(classify(v, m, my));
    }
    return out;
}

// Measured peaks (RSS high-water mark, grids of 1e3 to 2.5e5 unknowns): the
// Cholesky factor of K - sigma M under Eigen's minimum-degree ordering holds
// 3.4 to 6.9 n log2(n) nonzeros, and the factorisation and solve peak at 75 to
// 93 bytes per n log2(n) beyond the vectors; 150 is the estimate. Plus the
// column-major copies of K and K - sigma M (13 nonzeros a row, 12 bytes
// each), the Lanczos basis (ncv vectors) and the shapes with their scratch
// copies (3 x count vectors), 8 bytes per entry.
double lowest_modes_bytes(std::size_t unknowns, int count)
{
    const double n = double(std::max<std::size_t>(unknowns, 2));
    const double ncv = std::min(n, std::max(2.0 * count + 1, count + 20.0));
    const double factor = 150 * n * std::log2(n);
    const double matrices = 2 * 13 * n * 12;
    const double vectors = (ncv + 3.0 * count + 8) * n * 8;
    return factor + matrices + vectors;
}

// The assembly keeps the triplets of K and Gm (up to ~170 per node of 16
// bytes) next to the finished matrices: measured peak 2.7 to 2.9 kB per node.
double plate_operator_bytes(std::size_t nodes) { return 3500.0 * double(nodes); }

std::vector<double> mode_field(const PlateOperator &op, const Eigen::Ref<const Eigen::VectorXd> &shape)
{
    std::vector<double> field(op.grid().node_count(), 0.0);
    double peak = 0, signed_peak = 0;
    for (std::size_t u = 0; u < op.unknown_count(); ++u) {
        const double v = shape[Eigen::Index(u)];
        field[op.node_of()[u]] = v;
        if (std::abs(v) > peak) {
            peak = std::abs(v);
            signed_peak = v;
        }
    }
    if (peak > 0)
        for (double &v : field)
            v /= signed_peak;
    return field;
}

} // namespace calib::engine
