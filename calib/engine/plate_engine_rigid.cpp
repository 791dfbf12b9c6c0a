// The rigid-body momenta of a PlateEngine. A plate with free edges has
// rigid-body modes r (all free: 1, x, y; one supported edge and three free:
// the rotation about it). K r = 0 and M r are left null vectors of the
// update, so the scheme keeps p = r^T M d exactly (times g per step with
// sigma0 loss; sigma1 loss keeps only the modes with Gm r = 0). Stored in
// floating point, d is rounded at every node and step and p random-walks:
// ~ eps |d| sqrt(steps / nodes), a rigid drift growing as eps steps^1.5
// (measured: 2e2 x the field in 1e7 float steps of a 16 x 13 free plate at
// rest). The engine keeps the exact value of p (what sources and extensions
// add, in double) and every rigid_interval steps restores it by adding the
// rigid velocity that makes up the difference: a rank-3 correction in the
// null space of K, which moves no elastic mode (docs/engine.md, "Rigid-body
// modes in float").
#include "engine/plate_engine.h"

#include <Eigen/Dense>

#include <cmath>

namespace calib::engine {

template <typename T>
void PlateEngine<T>::build_rigid_modes()
{
    const PlateOperator &op = *op_;
    const Edges &e = op.params().edges;
    rigid_count_ = 0;
    if (e.none_free())
        return;
    const Eigen::Index n = Eigen::Index(op.unknown_count());
    Eigen::MatrixXd r(n, 3);
    for (Eigen::Index u = 0; u < n; ++u) {
        const std::size_t node = op.node_of()[std::size_t(u)];
        r(u, 0) = 1;
        r(u, 1) = double(node % std::size_t(nx_ + 1));
        r(u, 2) = double(node / std::size_t(nx_ + 1));
    }
    const Eigen::Matrix3d gram = r.transpose() * op.mass().asDiagonal() * r;
    if (Eigen::LLT<Eigen::Matrix3d>(gram).info() != Eigen::Success)
        return; // the unknowns lie on one line: no rigid mode to keep
    Eigen::Matrix3d form = (r.transpose() * (op.stiffness() * r)) / op.lambda_max_stiffness();
    if (op.params().loss.sigma1 > 0)
        form += (r.transpose() * (op.dirichlet() * r)) / op.lambda_max_dirichlet();
    // Generalized eigenvectors are M-orthonormal (b^T gram b = 1): the Gram
    // matrix of the kept modes is the identity.
    const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix3d> es(0.5 * (form + form.transpose()), gram);
    for (int c = 0; c < 3; ++c)
        if (std::abs(es.eigenvalues()[c]) < 1e-9) {
            for (int q = 0; q < 3; ++q)
                rigid_b_[std::size_t(rigid_count_)][std::size_t(q)] = es.eigenvectors()(q, c);
            ++rigid_count_;
        }
    const auto raw = raw_moments();
    for (int c = 0; c < rigid_count_; ++c)
        rigid_expected_[std::size_t(c)] = rigid_b_[std::size_t(c)][0] * raw[0] + rigid_b_[std::size_t(c)][1] * raw[1] +
                                          rigid_b_[std::size_t(c)][2] * raw[2];
}

// sum_n m_n (1, i, j) d_n over the unknowns.
template <typename T>
std::array<double, 3> PlateEngine<T>::raw_moments() const
{
    std::array<double, 3> q{};
    const PlateOperator &op = *op_;
    for (int j = 0; j <= ny_; ++j) {
        double s0 = 0, s1 = 0;
        for (int i = 0; i <= nx_; ++i) {
            const std::ptrdiff_t u = op.unknown_of()[op.grid().node(i, j)];
            if (u < 0)
                continue;
            const double md = op.mass()[Eigen::Index(u)] * double(inc_[j * stride_ + i]);
            s0 += md;
            s1 += md * i;
        }
        q[0] += s0;
        q[1] += s1;
        q[2] += s0 * j;
    }
    return q;
}

template <typename T>
void PlateEngine<T>::restore_rigid_momenta()
{
    const auto raw = raw_moments();
    double a0 = 0, a1 = 0, a2 = 0; // the correction a0 + a1 i + a2 j
    for (int c = 0; c < rigid_count_; ++c) {
        const auto &b = rigid_b_[std::size_t(c)];
        const double gap = rigid_expected_[std::size_t(c)] - (b[0] * raw[0] + b[1] * raw[1] + b[2] * raw[2]);
        a0 += gap * b[0];
        a1 += gap * b[1];
        a2 += gap * b[2];
    }
    if (a0 == 0 && a1 == 0 && a2 == 0)
        return;
    const PlateOperator &op = *op_;
    for (int j = 0; j <= ny_; ++j)
        for (int i = 0; i <= nx_; ++i)
            if (op.unknown_of()[op.grid().node(i, j)] >= 0)
                inc_[j * stride_ + i] += T(a0 + a1 * i + a2 * j);
}

#define PLATE_ENGINE_RIGID(T)                                                                                          \
    template void PlateEngine<T>::build_rigid_modes();                                                                 \
    template std::array<double, 3> PlateEngine<T>::raw_moments() const;                                                \
    template void PlateEngine<T>::restore_rigid_momenta();
PLATE_ENGINE_RIGID(float)
PLATE_ENGINE_RIGID(double)
#undef PLATE_ENGINE_RIGID

} // namespace calib::engine
