// Modal frequencies of the scheme against independent truth: the discrete
// dispersion relation of the 13-point scheme (simply supported, exact to
// round-off), the continuum Kirchhoff values (second-order convergence), and
// Leissa's tabulated clamped and free square plates.
#include "engine/spectrum.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace plate_test;
using std::numbers::pi;

namespace {

struct ModeRun {
    double omega;         // measured angular frequency (rad/s)
    double impurity;      // max ||u - s v|| / ||v|| over the run (started at u = v)
    double omega_formula; // (2/k) asin(2 mu [sin^2(m pi h/2a) + sin^2(n pi h/2b)])
    double omega_continuum;
};

// Starts the simply supported plate in the sine mode (m, n), runs the scheme
// and measures the frequency from the recurrence s+ + s- = 2 cos(omega k) s of
// the mode's amplitude s (least squares over the whole run).
ModeRun run_sine_mode(int nx, int ny, double h, int m, int n, std::size_t steps)
{
    auto op = make_plate(nx, ny, h, Edges::all(EdgeKind::simply_supported));
    const double k = 0.9 * op->max_time_step();
    PlateEngine<double> eng(op, k);
    const double a = nx * h, b = ny * h;
    std::vector<double> v(op->grid().node_count());
    double vv = 0;
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            const double x = std::sin(m * pi * i * h / a) * std::sin(n * pi * j * h / b);
            v[op->grid().node(i, j)] = x;
            vv += x * x;
        }
    eng.set_state(v, v);
    std::vector<double> s{1.0};
    double impurity = 0;
    for (std::size_t t = 0; t < steps; ++t) {
        eng.step();
        const std::vector<double> u = eng.displacement();
        double uv = 0;
        for (std::size_t q = 0; q < u.size(); ++q)
            uv += u[q] * v[q];
        const double amp = uv / vv;
        double r = 0;
        for (std::size_t q = 0; q < u.size(); ++q)
            r += (u[q] - amp * v[q]) * (u[q] - amp * v[q]);
        impurity = std::max(impurity, std::sqrt(r / vv));
        s.push_back(amp);
    }
    double num = 0, den = 0;
    for (std::size_t t = 1; t + 1 < s.size(); ++t) {
        num += (s[t + 1] + s[t - 1]) * s[t];
        den += 2 * s[t] * s[t];
    }
    const double c = num / den;
    ModeRun out;
    out.omega = std::acos(c) / k;
    out.impurity = impurity;
    const double mu = op->kappa() * k / (h * h);
    const double sx = std::sin(m * pi * h / (2 * a)), sy = std::sin(n * pi * h / (2 * b));
    out.omega_formula = 2 / k * std::asin(2 * mu * (sx * sx + sy * sy));
    out.omega_continuum = op->kappa() * (std::pow(m * pi / a, 2) + std::pow(n * pi / b, 2));
    return out;
}

double order(double e1, double e2) { return std::log2(std::abs(e1) / std::abs(e2)); }

} // namespace

TEST(PlateModes, SimplySupportedMatchesDiscreteDispersionRelation)
{
    const int modes[][2] = {{1, 1}, {2, 3}, {5, 2}, {7, 6}};
    for (auto [m, n] : modes) {
        const ModeRun r = run_sine_mode(25, 20, 0.02, m, n, 400);
        EXPECT_LT(r.impurity, 1e-11) << "mode " << m << "," << n << " is not an eigenvector of the scheme";
        EXPECT_NEAR(r.omega / r.omega_formula, 1.0, 1e-9) << "mode " << m << "," << n;
    }
}

TEST(PlateModes, SimplySupportedConvergesToContinuumAtSecondOrder)
{
    // a x b = 0.5 x 0.4 m with h = a/10, a/20, a/40; mode (2, 1).
    double err[3];
    for (int level = 0; level < 3; ++level) {
        const int nx = 10 << level, ny = 8 << level;
        const ModeRun r = run_sine_mode(nx, ny, 0.5 / nx, 2, 1, 300);
        err[level] = r.omega / r.omega_continuum - 1;
    }
    EXPECT_LT(std::abs(err[2]), 2e-3);
    EXPECT_NEAR(order(err[0], err[1]), 2.0, 0.1);
    EXPECT_NEAR(order(err[1], err[2]), 2.0, 0.05);
    std::printf("simply supported (2,1): relative errors %.3e %.3e %.3e, orders %.3f %.3f\n", err[0], err[1], err[2],
                order(err[0], err[1]), order(err[1], err[2]));
}

namespace {

// Non-dimensional frequency lambda^2 = omega a^2 sqrt(rho d / D) of the
// `index`-th (0-based) mode of the assembled operator of a square plate.
double square_lambda2(int n, EdgeKind edges, double nu, int index, double shift_lambda2)
{
    const double a = 1.0;
    auto op = make_plate(n, n, a / n, Edges::all(edges), nu);
    const double scale =
        a * a * std::sqrt(op->params().material.density_kg_m3 * op->params().thickness_m / op->bending_stiffness());
    const double shift = std::pow(shift_lambda2 / scale, 2);
    const auto lam = lowest_generalized_eigenvalues(op->stiffness(), op->mass(), index + 1, shift);
    return std::sqrt(std::max(lam[std::size_t(index)], 0.0)) * scale;
}

} // namespace

TEST(PlateModes, ClampedSquareFirstModeConvergesToLeissa)
{
    // Leissa (1969), clamped square plate, first mode: lambda^2 = 35.99.
    double l[3];
    for (int level = 0; level < 3; ++level)
        l[level] = square_lambda2(10 << level, EdgeKind::clamped, 0.3, 0, 10.0);
    const double p = order(l[0] - l[1], l[1] - l[2]);
    const double extrapolated = l[2] + (l[2] - l[1]) / (std::pow(2.0, p) - 1);
    std::printf("clamped square lambda^2: %.5f %.5f %.5f, order %.3f, extrapolated %.5f\n", l[0], l[1], l[2], p,
                extrapolated);
    EXPECT_NEAR(p, 2.0, 0.15);
    EXPECT_NEAR(extrapolated, 35.99, 0.02);
    EXPECT_NEAR(l[2], 35.99, 0.3);
}

TEST(PlateModes, FreeSquareRigidModesAndFirstElasticMode)
{
    // Leissa (1969), free square plate, nu = 0.3: first elastic mode (the
    // twisting mode) lambda^2 = 13.47; three rigid-body modes at 0.
    double l[3];
#ifdef HAPTIC_ASAN
    const int base = 8;
#else
    const int base = 10;
#endif
    for (int level = 0; level < 3; ++level) {
        const int n = base << level;
        auto op = make_plate(n, n, 1.0 / n, Edges::all(EdgeKind::free), 0.3);
        const double scale =
            std::sqrt(op->params().material.density_kg_m3 * op->params().thickness_m / op->bending_stiffness());
        const double shift = std::pow(1.0 / scale, 2);
        const auto lam = lowest_generalized_eigenvalues(op->stiffness(), op->mass(), 4, shift);
        const double elastic = std::sqrt(lam[3]) * scale;
        // Rigid-body motions (translation, two tilts) store no energy: K r = 0
        // to round-off, and the three lowest frequencies are ~0 (to the
        // round-off of a Rayleigh quotient, ~sqrt(eps * lambda_max)).
        Eigen::VectorXd one(op->unknown_count()), tx(op->unknown_count()), ty(op->unknown_count());
        for (std::size_t u = 0; u < op->unknown_count(); ++u) {
            const std::size_t node = op->node_of()[u];
            one[Eigen::Index(u)] = 1.0;
            tx[Eigen::Index(u)] = double(node % std::size_t(n + 1)) / n - 0.5;
            ty[Eigen::Index(u)] = double(node / std::size_t(n + 1)) / n - 0.5;
        }
        const double knorm = op->stiffness().cwiseAbs().sum() / double(op->unknown_count());
        for (const Eigen::VectorXd *r : {&one, &tx, &ty})
            EXPECT_LT((op->stiffness() * *r).norm(), 1e-13 * knorm * r->norm());
        for (int r = 0; r < 3; ++r)
            EXPECT_LT(std::sqrt(std::abs(lam[std::size_t(r)])) * scale, 1e-3 * elastic) << "rigid mode " << r;
        l[level] = elastic;
    }
    const double p = order(l[0] - l[1], l[1] - l[2]);
    const double extrapolated = l[2] + (l[2] - l[1]) / (std::pow(2.0, p) - 1);
    std::printf("free square lambda^2: %.5f %.5f %.5f, order %.3f, extrapolated %.5f\n", l[0], l[1], l[2], p,
                extrapolated);
    EXPECT_NEAR(p, 2.0, 0.2);
    EXPECT_NEAR(extrapolated, 13.47, 0.02);
}

TEST(PlateModes, InteriorRowsAreThe13PointStencil)
{
    // Inside, M^-1 K is kappa^2 / h^4 times the 13-point biharmonic whatever
    // nu and the edges are (hand-written stencil: 20, -8, 2, 1).
    for (double nu : {0.0, 0.3, 0.45}) {
        const double h = 0.01;
        auto op =
            make_plate(9, 8, h, {EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported}, nu);
        const double scale = op->kappa() * op->kappa() / std::pow(h, 4);
        const int ci = 4, cj = 4;
        const auto row = op->unknown_of()[op->grid().node(ci, cj)];
        const double minv = 1.0 / op->mass()[row];
        for (int dj = -3; dj <= 3; ++dj)
            for (int di = -3; di <= 3; ++di) {
                const int ad = std::abs(di) + std::abs(dj);
                double expect = 0;
                if (ad == 0)
                    expect = 20;
                else if (ad == 1)
                    expect = -8;
                else if (ad == 2 && di != 0 && dj != 0)
                    expect = 2;
                else if (ad == 2)
                    expect = 1;
                const auto col = op->unknown_of()[op->grid().node(ci + di, cj + dj)];
                ASSERT_GE(col, 0);
                EXPECT_NEAR(op->stiffness().coeff(row, col) * minv / scale, expect, 1e-12)
                    << "nu " << nu << " offset " << di << "," << dj;
            }
    }
}
