// The plate's eigenmodes (engine/modes.h) against independent truth: the
// engine's own stencil application, the exact discrete and the continuum
// simply supported modes, Leissa's clamped and free squares, the rigid-body
// motions of a free plate, a second eigensolver (spectrum.h's subspace
// iteration), and the measured memory of the solve.
#include "engine/modes.h"
#include "engine/spectrum.h"
#include "model/resources.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

using namespace plate_test;
using std::numbers::pi;

namespace {

double order(double e1, double e2) { return std::log2(std::abs(e1) / std::abs(e2)); }

// Non-dimensional frequency lambda^2 = omega a^2 sqrt(rho d / D) of a square
// plate of side a.
double lambda2(const PlateOperator &op, double omega2)
{
    const double a = op.grid().length_x_m();
    const double rho_d = op.params().material.density_kg_m3 * op.params().thickness_m;
    return std::sqrt(std::max(omega2, 0.0)) * a * a * std::sqrt(rho_d / op.bending_stiffness());
}

struct SineMode {
    int m, n;
    double omega2_discrete; // of M^-1 K: (kappa * 4/h^2 (sin^2(m pi h/2a) + sin^2(n pi h/2b)))^2
    double laplacian;       // of the discrete -laplacian: 4/h^2 (...)
    double omega_continuum; // kappa ((m pi/a)^2 + (n pi/b)^2)
};

// The simply supported modes of a nx x ny grid, lowest first: on this scheme
// the sines are exact eigenvectors of both K and Gm (docs/physics.md, Energy, modes and reciprocity).
std::vector<SineMode> sine_modes(const PlateOperator &op)
{
    const Grid &g = op.grid();
    const double a = g.length_x_m(), b = g.length_y_m(), h = g.h;
    std::vector<SineMode> out;
    for (int m = 1; m < g.nx; ++m)
        for (int n = 1; n < g.ny; ++n) {
            const double sx = std::sin(m * pi * h / (2 * a)), sy = std::sin(n * pi * h / (2 * b));
            const double lap = 4 / (h * h) * (sx * sx + sy * sy);
            out.push_back({m, n, std::pow(op.kappa() * lap, 2), lap,
                           op.kappa() * (std::pow(m * pi / a, 2) + std::pow(n * pi / b, 2))});
        }
    std::sort(out.begin(), out.end(),
              [](const SineMode &x, const SineMode &y) { return x.omega2_discrete < y.omega2_discrete; });
    return out;
}

} // namespace

TEST(Modes, EngineStepAppliesTheAssembledOperator)
{
    // Second method: the engine never multiplies by the assembled K; it runs
    // the 13-point bulk kernel inside and its factored edge rows near the
    // edges. Started at rest in v (u^n = u^{n-1} = v), one lossless step gives
    // u^{n+1} = v - k^2 M^-1 K v, so (v - u^{n+1}) / k^2 must be the assembled
    // M^-1 K v, for every edge combination.
    for (const Edges &e : all_edge_combinations()) {
        auto op = make_plate(14, 11, 0.01, e, 0.33);
        const double k = 0.5 * op->max_time_step();
        PlateEngine<double> eng(op, k);
        for (unsigned seed : {1u, 2u}) {
            const std::vector<double> v = random_field(*op, seed);
            eng.set_state(v, v);
            eng.step();
            const std::vector<double> u = eng.displacement();
            Eigen::VectorXd vu(op->unknown_count()), stepped(op->unknown_count());
            for (std::size_t q = 0; q < op->unknown_count(); ++q) {
                const std::size_t node = op->node_of()[q];
                vu[Eigen::Index(q)] = v[node];
                stepped[Eigen::Index(q)] = (v[node] - u[node]) / (k * k);
            }
            const Eigen::VectorXd assembled = (op->stiffness() * vu).cwiseQuotient(op->mass());
            EXPECT_LT((stepped - assembled).norm(), 1e-9 * assembled.norm()) << describe(e);
            for (std::size_t node = 0; node < u.size(); ++node)
                if (op->unknown_of()[node] < 0) {
                    EXPECT_EQ(u[node], 0.0) << describe(e);
                }
        }
    }
}

TEST(Modes, SimplySupportedRectangleIsTheExactDiscreteSineSpectrum)
{
    // Every eigenvalue, multiplicities included, is the discrete sine mode's
    // to round-off; the parity follows m and n (mode (m, n) is symmetric
    // about x = a/2 iff m is odd); the loss is sigma0 + sigma1 times the sine's
    // discrete -laplacian eigenvalue.
    Loss loss{0.7, 2e-4};
    for (auto [nx, ny] : {std::pair{25, 20}, std::pair{20, 20}}) {
        auto op = make_plate(nx, ny, 0.02, Edges::all(EdgeKind::simply_supported), 0.3, loss);
        const std::vector<SineMode> truth = sine_modes(*op);
        const int count = 12;
        const PlateModes modes = lowest_modes(*op, count);
        ASSERT_EQ(modes.frequency_hz.size(), std::size_t(count));
        for (int c = 0; c < count; ++c) {
            const std::size_t i = std::size_t(c);
            EXPECT_NEAR(modes.eigenvalue_rad2_s2[i] / truth[i].omega2_discrete, 1.0, 1e-9)
                << nx << "x" << ny << " mode " << c;
            EXPECT_NEAR(modes.frequency_hz[i], std::sqrt(truth[i].omega2_discrete) / (2 * pi),
                        1e-9 * modes.frequency_hz[i]);
            EXPECT_NEAR(modes.decay_rate_1_s[i], loss.sigma0 + loss.sigma1 * truth[i].laplacian, 1e-8) << c;
        }
        // Parity: for each (m, n) with a unique frequency the mode's class is
        // known; a square's degenerate pair (m, n), (n, m) with m + n odd is
        // one (sym, anti) and one (anti, sym) mode.
        auto parity = [](int k) { return k % 2 ? Parity::symmetric : Parity::antisymmetric; };
        std::vector<std::pair<Parity, Parity>> expected, got;
        for (int c = 0; c < count; ++c) {
            expected.emplace_back(parity(truth[std::size_t(c)].m), parity(truth[std::size_t(c)].n));
            got.emplace_back(modes.parity_x[std::size_t(c)], modes.parity_y[std::size_t(c)]);
        }
        // Compare as multisets within each group of equal frequency (a group
        // cut by the count is left out: any of its members may be the one).
        for (int a = 0; a < count;) {
            int b = a + 1;
            while (std::size_t(b) < truth.size() &&
                   truth[std::size_t(b)].omega2_discrete < truth[std::size_t(a)].omega2_discrete * (1 + 1e-9))
                ++b;
            if (b > count)
                break;
            std::vector<std::pair<Parity, Parity>> e(expected.begin() + a, expected.begin() + b),
                g(got.begin() + a, got.begin() + b);
            std::sort(e.begin(), e.end());
            std::sort(g.begin(), g.end());
            EXPECT_EQ(e, g) << nx << "x" << ny << " modes " << a << ".." << b - 1;
            a = b;
        }
    }
}

TEST(Modes, SimplySupportedConvergesToTheContinuumAtSecondOrder)
{
    // a x b = 0.5 x 0.4 m at h = a/10, a/20, a/40: the four lowest modes
    // against kappa ((m pi/a)^2 + (n pi/b)^2), relative error O(h^2).
    const int count = 4;
    double err[3][count];
    for (int level = 0; level < 3; ++level) {
        const int nx = 10 << level, ny = 8 << level;
        auto op = make_plate(nx, ny, 0.5 / nx, Edges::all(EdgeKind::simply_supported));
        const std::vector<SineMode> truth = sine_modes(*op);
        const PlateModes modes = lowest_modes(*op, count);
        for (int c = 0; c < count; ++c) {
            const SineMode &t = truth[std::size_t(c)];
            err[level][c] = 2 * pi * modes.frequency_hz[std::size_t(c)] / t.omega_continuum - 1;
        }
    }
    for (int c = 0; c < count; ++c) {
        std::printf("simply supported mode %d: relative errors %.3e %.3e %.3e, orders %.3f %.3f\n", c + 1, err[0][c],
                    err[1][c], err[2][c], order(err[0][c], err[1][c]), order(err[1][c], err[2][c]));
        EXPECT_LT(err[2][c], 0.0) << "the 13-point scheme's modes lie below the continuum";
        EXPECT_LT(std::abs(err[2][c]), 6e-3) << c;
        EXPECT_NEAR(order(err[0][c], err[1][c]), 2.0, 0.1) << c;
        EXPECT_NEAR(order(err[1][c], err[2][c]), 2.0, 0.03) << c;
    }
}

TEST(Modes, ClampedSquareFirstModeConvergesToLeissa)
{
    // Leissa (1969), clamped square plate, first mode: lambda^2 = 35.99,
    // doubly symmetric.
    double l[3];
    for (int level = 0; level < 3; ++level) {
        const int n = 12 << level;
        auto op = make_plate(n, n, 0.6 / n, Edges::all(EdgeKind::clamped));
        const PlateModes modes = lowest_modes(*op, 3);
        l[level] = lambda2(*op, modes.eigenvalue_rad2_s2[0]);
        EXPECT_EQ(modes.parity_x[0], Parity::symmetric);
        EXPECT_EQ(modes.parity_y[0], Parity::symmetric);
        // The next two: the degenerate (1, 2) / (2, 1) pair, one of each parity.
        EXPECT_NEAR(modes.eigenvalue_rad2_s2[1] / modes.eigenvalue_rad2_s2[2], 1.0, 1e-9);
        EXPECT_NE(modes.parity_x[1], modes.parity_x[2]);
        EXPECT_NE(modes.parity_x[1], Parity::mixed);
        EXPECT_NE(modes.parity_x[2], Parity::mixed);
    }
    const double p = order(l[0] - l[1], l[1] - l[2]);
    const double extrapolated = l[2] + (l[2] - l[1]) / (std::pow(2.0, p) - 1);
    std::printf("clamped square lambda^2: %.5f %.5f %.5f, order %.3f, extrapolated %.5f\n", l[0], l[1], l[2], p,
                extrapolated);
    EXPECT_NEAR(p, 2.0, 0.15);
    EXPECT_NEAR(extrapolated, 35.99, 0.02);
    EXPECT_NEAR(l[2], 35.99, 0.2);
    EXPECT_LT(std::abs(l[2] - 35.99), std::abs(l[1] - 35.99));
    EXPECT_LT(std::abs(l[1] - 35.99), std::abs(l[0] - 35.99));
}

TEST(Modes, FreeSquareHasThreeRigidModesThenTheTwist)
{
    // Leissa (1969), free square, nu = 0.3: the first elastic mode is the
    // twist (w ~ x y, antisymmetric about both centre lines), lambda^2 = 13.47.
    // Below it, the three rigid-body motions at zero frequency: in the mirror
    // basis the translation (sym, sym) and the tilts (anti, sym), (sym, anti),
    // each a linear field.
    double l[3];
    for (int level = 0; level < 3; ++level) {
        const int n = 10 << level;
        auto op = make_plate(n, n, 0.5 / n, Edges::all(EdgeKind::free), 0.3);
        const PlateModes modes = lowest_modes(*op, 5);
        const double elastic = lambda2(*op, modes.eigenvalue_rad2_s2[3]);
        for (int r = 0; r < 3; ++r) {
            const std::size_t i = std::size_t(r);
            // Round-off of a Rayleigh quotient: ~sqrt(eps * lambda_max).
            EXPECT_LT(lambda2(*op, std::abs(modes.eigenvalue_rad2_s2[i])), 1e-3 * elastic) << "rigid mode " << r;
            // A rigid shape is a plane: every second difference vanishes.
            const std::vector<double> w = mode_field(*op, modes.shapes.col(r));
            double curvature = 0;
            for (int j = 0; j <= n; ++j)
                for (int x = 1; x < n; ++x)
                    curvature =
                        std::max(curvature, std::abs(w[op->grid().node(x + 1, j)] - 2 * w[op->grid().node(x, j)] +
                                                     w[op->grid().node(x - 1, j)]));
            EXPECT_LT(curvature, 1e-6) << "rigid mode " << r;
        }
        std::vector<std::pair<Parity, Parity>> rigid, want = {{Parity::symmetric, Parity::symmetric},
                                                              {Parity::symmetric, Parity::antisymmetric},
                                                              {Parity::antisymmetric, Parity::symmetric}};
        for (std::size_t r = 0; r < 3; ++r)
            rigid.emplace_back(modes.parity_x[r], modes.parity_y[r]);
        std::sort(rigid.begin(), rigid.end());
        std::sort(want.begin(), want.end());
        EXPECT_EQ(rigid, want);
        EXPECT_EQ(modes.parity_x[3], Parity::antisymmetric);
        EXPECT_EQ(modes.parity_y[3], Parity::antisymmetric);
        EXPECT_GT(modes.eigenvalue_rad2_s2[4], modes.eigenvalue_rad2_s2[3] * 1.1);
        l[level] = elastic;
    }
    const double p = order(l[0] - l[1], l[1] - l[2]);
    const double extrapolated = l[2] + (l[2] - l[1]) / (std::pow(2.0, p) - 1);
    std::printf("free square twist lambda^2: %.5f %.5f %.5f, order %.3f, extrapolated %.5f\n", l[0], l[1], l[2], p,
                extrapolated);
    EXPECT_NEAR(p, 2.0, 0.2);
    EXPECT_NEAR(extrapolated, 13.47, 0.02);
}

TEST(Modes, MixedEdgesAgreeWithASecondEigensolver)
{
    // Free left and bottom edges meeting at a free corner, clamped right,
    // simply supported top: no rigid mode, no mirror symmetry. Spectra's
    // Lanczos against the block subspace iteration of spectrum.h (another
    // algorithm on the same matrices), the shapes M-orthonormal, each pair an
    // eigenpair to a small residual.
    auto op = make_plate(24, 18, 0.0125,
                         {EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported}, 0.33);
    const int count = 8;
    const PlateModes modes = lowest_modes(*op, count);
    const std::vector<double> other = lowest_generalized_eigenvalues(op->stiffness(), op->mass(), count, 1.0);
    const Eigen::MatrixXd &v = modes.shapes;
    const Eigen::MatrixXd gram = v.transpose() * op->mass().asDiagonal() * v;
    EXPECT_LT((gram - Eigen::MatrixXd::Identity(count, count)).cwiseAbs().maxCoeff(), 1e-9);
    for (int c = 0; c < count; ++c) {
        const std::size_t i = std::size_t(c);
        EXPECT_GT(modes.frequency_hz[i], 0.0);
        if (c > 0) {
            EXPECT_GT(modes.frequency_hz[i], modes.frequency_hz[i - 1] * (1 + 1e-6)) << c;
        }
        EXPECT_NEAR(modes.eigenvalue_rad2_s2[i] / other[i], 1.0, 1e-9) << c;
        const Eigen::VectorXd r =
            op->stiffness() * v.col(c) - modes.eigenvalue_rad2_s2[i] * op->mass().cwiseProduct(v.col(c));
        EXPECT_LT(r.norm(), 1e-7 * modes.eigenvalue_rad2_s2[i] * op->mass().cwiseProduct(v.col(c)).norm()) << c;
        EXPECT_EQ(modes.parity_x[i], Parity::not_applicable);
        EXPECT_EQ(modes.parity_y[i], Parity::not_applicable);
        EXPECT_EQ(modes.decay_rate_1_s[i], 0.0);
    }
    // The free corner moves in the lowest mode; clamped and supported nodes never do.
    const std::vector<double> w = mode_field(*op, v.col(0));
    EXPECT_GT(std::abs(w[op->grid().node(0, 0)]), 0.1);
    EXPECT_EQ(w[op->grid().node(24, 5)], 0.0);
    EXPECT_EQ(w[op->grid().node(5, 18)], 0.0);
    EXPECT_DOUBLE_EQ(*std::max_element(w.begin(), w.end()), 1.0);
}

TEST(Modes, RefusesCountsOutsideOneToUnknownsMinusOne)
{
    auto op = make_plate(4, 3, 0.05, Edges::all(EdgeKind::clamped)); // 3 x 2 = 6 unknowns
    ASSERT_EQ(op->unknown_count(), 6u);
    EXPECT_THROW(lowest_modes(*op, 0), std::invalid_argument);
    EXPECT_THROW(lowest_modes(*op, -3), std::invalid_argument);
    EXPECT_THROW(lowest_modes(*op, 6), std::invalid_argument);
    const PlateModes all_but_one = lowest_modes(*op, 5);
    EXPECT_EQ(all_but_one.frequency_hz.size(), 5u);
    const std::vector<double> other = lowest_generalized_eigenvalues(op->stiffness(), op->mass(), 5, 1.0);
    for (std::size_t i = 0; i < 5; ++i)
        EXPECT_NEAR(all_but_one.eigenvalue_rad2_s2[i] / other[i], 1.0, 1e-9) << i;
}

#ifndef HAPTIC_ASAN // the sanitizers' shadow memory is not what a release run needs
TEST(Modes, MemoryEstimateBoundsTheMeasuredPeak)
{
    // The refusal of `calibgen modes` trusts these estimates: they must not
    // be below what the operator's assembly and the solve really take (RSS
    // high-water mark), nor so far above that a feasible job is refused.
    const int nx = 150, ny = 120;
    calib::model::reset_peak_rss();
    double before = calib::model::current_rss_mb();
    auto op = make_plate(nx, ny, 0.004, Edges::all(EdgeKind::free));
    (void)op->stiffness(); // assembled on first use: the modes need them
    const double op_mb = calib::model::peak_rss_mb() - before;
    calib::model::reset_peak_rss();
    before = calib::model::current_rss_mb();
    const PlateModes modes = lowest_modes(*op, 20);
    const double solve_mb = calib::model::peak_rss_mb() - before;
    const double mb = 1024.0 * 1024.0;
    const double op_predicted = plate_operator_bytes(op->grid().node_count()) / mb;
    const double solve_predicted = lowest_modes_bytes(op->unknown_count(), 20) / mb;
    std::printf("operator: measured %.1f MB, estimated %.1f MB; solve: measured %.1f MB, estimated %.1f MB\n", op_mb,
                op_predicted, solve_mb, solve_predicted);
    EXPECT_LE(op_mb, op_predicted);
    EXPECT_LE(solve_mb, solve_predicted);
    EXPECT_GE(op_mb, op_predicted / 3);
    EXPECT_GE(solve_mb, solve_predicted / 3);
    EXPECT_EQ(modes.frequency_hz.size(), 20u);
}
#endif
