// The thick-plate (Mindlin) effect against independent results. The phase
// velocity is measured FROM THE SIMULATION: a simply supported plate started
// in mode (m, n) rings at its modal frequency, measured from the zero
// crossings of the modal coordinate; c = omega / beta with beta the mode's
// wavenumber. At f*d ~ 250 kHz mm (8 mm glass, 30-40 kHz) it is compared
// with the exact Rayleigh-Lamb A0 (physics::a0_phase_velocity), Mindlin's
// continuum dispersion (physics::mindlin_phase_velocity) and Kirchhoff.
// Also: exact energy conservation (simply supported and clamped edges), the
// scheme's own stability bound.
#include "engine/mindlin/mindlin_engine.h"
#include "physics/dispersion.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

using namespace plate_test;
using namespace calib::engine::mindlin;
namespace physics = calib::physics;

namespace {

constexpr double pi = std::numbers::pi;

std::shared_ptr<MindlinOperator> mindlin_plate(int nx, int ny, double h, double d, Edges edges)
{
    PlateParams p;
    p.size_x_m = nx * h;
    p.size_y_m = ny * h;
    p.thickness_m = d;
    p.material = physics::material_from_elastic(2500.0, 70e9, 0.22, "glass"); // self-consistent
    p.edges = edges;
    return std::make_shared<MindlinOperator>(p, Grid{nx, ny, h});
}

// Mode (p, q): w = sin x sin and psi = -alpha grad_h w (the flexural
// eigenvector's rotation is parallel to the gradient; alpha from the w
// equation rho d omega^2 = S beta^2 (1 - alpha) with the expected omega), so the
// thickness-shear branch is barely excited and does not jitter the zero crossings.
Eigen::VectorXd mode_state(const MindlinOperator &op, int p, int q, double alpha)
{
    const Grid &g = op.grid();
    auto w = [&](int i, int j) { return 1e-6 * std::sin(p * pi * i / g.nx) * std::sin(q * pi * j / g.ny); };
    Eigen::VectorXd s = Eigen::VectorXd::Zero(Eigen::Index(op.unknown_count()));
    for (int j = 0; j <= g.ny; ++j)
        for (int i = 0; i <= g.nx; ++i) {
            if (auto u = op.w_index(i, j); u >= 0)
                s[u] = w(i, j);
            if (auto u = op.psi_x_index(i, j); u >= 0)
                s[u] = -alpha * (w(i + 1, j) - w(i, j)) / g.h;
            if (auto u = op.psi_y_index(i, j); u >= 0)
                s[u] = -alpha * (w(i, j + 1) - w(i, j)) / g.h;
        }
    return s;
}

double measure_omega(MindlinEngine &eng, const Eigen::VectorXd &shape, std::size_t steps)
{
    const Eigen::Index nw = Eigen::Index(eng.plate().w_count());
    const Eigen::VectorXd sw = shape.head(nw);
    double first = -1, last = -1, prev = 0;
    int count = 0;
    for (std::size_t n = 0; n < steps; ++n) {
        eng.step();
        const double a = eng.state().head(nw).dot(sw);
        if (n > 0 && (prev < 0) != (a < 0)) {
            const double t = (double(n) - 1 + prev / (prev - a)) * eng.time_step();
            if (first < 0)
                first = t;
            else
                ++count;
            last = t;
        }
        prev = a;
    }
    return pi * count / (last - first);
}

// Mindlin's flexural omega for wavenumber beta, by inverting
// physics::mindlin_phase_velocity (bisection on f).
double mindlin_omega(const physics::Material &m, double d, double beta)
{
    double lo = 1.0, hi = 1e7;
    for (int it = 0; it < 200; ++it) {
        const double f = std::sqrt(lo * hi);
        const double k = 2 * pi * f / physics::mindlin_phase_velocity(m, d, f);
        (k < beta ? lo : hi) = f;
    }
    return 2 * pi * std::sqrt(lo * hi);
}

} // namespace

TEST(EffectThickPlate, PhaseVelocityFromTheSimulationFollowsExactA0WhereKirchhoffFails)
{
    // 8 mm glass, 60 x 30 mm simply supported, h = 1 mm.
    const int nx = 60, ny = 30;
    const double h = 0.001, d = 0.008;
    auto op = mindlin_plate(nx, ny, h, d, Edges::all(EdgeKind::simply_supported));
    const physics::Material &mat = op->params().material;
    const double k = 0.95 * op->max_time_step();
    for (auto [p, q] : {std::pair{1, 1}, std::pair{2, 1}}) {
        const double bx = p * pi / (nx * h), by = q * pi / (ny * h);
        const double beta = std::hypot(bx, by);
        // What the scheme should give: Mindlin's dispersion with beta ->
        // (2/h) sin(beta h / 2) per component, and leapfrog's time warp.
        const double bdx = 2 / h * std::sin(bx * h / 2), bdy = 2 / h * std::sin(by * h / 2);
        const double om_disc = mindlin_omega(mat, d, std::hypot(bdx, bdy));
        const double om_discrete = 2 / k * std::asin(k * om_disc / 2);
        const double alpha =
            1 - mat.density_kg_m3 * d * om_disc * om_disc / (op->shear_stiffness() * (bdx * bdx + bdy * bdy));
        MindlinEngine eng(op, k);
        const Eigen::VectorXd s = mode_state(*op, p, q, alpha);
        eng.set_state(s, s);
        // ~10 periods (4 under the sanitizers).
        const std::size_t steps = std::size_t((run_scale < 1 ? 4 : 10) * 2 * pi / om_discrete / k);
        const double omega = measure_omega(eng, s, steps);
        const double f = omega / (2 * pi);
        const double c_sim = omega / beta;
        const double c_a0 = physics::a0_phase_velocity(mat, d, f);
        const double c_kirchhoff = physics::kirchhoff_phase_velocity(mat, d, f);
        const double c_mindlin = physics::mindlin_phase_velocity(mat, d, f);
        SCOPED_TRACE("mode (" + std::to_string(p) + "," + std::to_string(q) + "), f = " + std::to_string(f) +
                     " Hz, f*d = " + std::to_string(f * d * 1e3) + " kHz mm");
        // The scheme against its discrete dispersion: exact up to the measurement.
        EXPECT_NEAR(omega / om_discrete - 1, 0.0, 1e-6);
        // The physics: Kirchhoff is several % off here, the thick-plate
        // scheme within 1 % of exact A0 and within its grid error of Mindlin.
        const double err_sim = std::abs(c_sim / c_a0 - 1), err_k = std::abs(c_kirchhoff / c_a0 - 1);
        EXPECT_GT(err_k, 0.04);
        EXPECT_LT(err_sim, 0.01);
        EXPECT_LT(err_sim, err_k / 5);
        EXPECT_NEAR(c_sim / c_mindlin - 1, 0.0, 2e-3);
        RecordProperty("mode_" + std::to_string(p) + std::to_string(q),
                       "f=" + std::to_string(f) + " c_sim=" + std::to_string(c_sim) + " c_A0=" + std::to_string(c_a0) +
                           " c_Mindlin=" + std::to_string(c_mindlin) + " c_Kirchhoff=" + std::to_string(c_kirchhoff));
    }
}

TEST(EffectThickPlate, EnergyIsConservedForSupportedAndClampedEdges)
{
    for (Edges e :
         {Edges::all(EdgeKind::simply_supported), Edges::all(EdgeKind::clamped),
          Edges{EdgeKind::clamped, EdgeKind::simply_supported, EdgeKind::simply_supported, EdgeKind::clamped}}) {
        auto op = mindlin_plate(14, 11, 0.002, 0.006, e);
        MindlinEngine eng(op, 0.99 * op->max_time_step());
        std::mt19937_64 rng(7);
        std::uniform_real_distribution<double> u(-1, 1);
        Eigen::VectorXd a(Eigen::Index(op->unknown_count())), b(Eigen::Index(op->unknown_count()));
        for (Eigen::Index i = 0; i < a.size(); ++i) {
            a[i] = 1e-6 * u(rng);
            b[i] = 1e-6 * u(rng);
        }
        eng.set_state(a, b);
        const double e0 = eng.energy();
        ASSERT_GT(e0, 0);
        double worst = 0, peak = 0;
        for (std::size_t n = 0; n < scaled(20000); ++n) {
            eng.step();
            worst = std::max(worst, std::abs(eng.energy() / e0 - 1));
            peak = std::max(peak, eng.state().cwiseAbs().maxCoeff());
        }
        SCOPED_TRACE(describe(e));
        EXPECT_LT(worst, 1e-11);
        EXPECT_LT(peak, 1e-2); // bounded at 0.99 x its own bound
    }
}

TEST(EffectThickPlate, OwnStabilityBoundIsEnforcedAndReal)
{
    auto op = mindlin_plate(10, 8, 0.002, 0.006, Edges::all(EdgeKind::simply_supported));
    const double bound = op->max_time_step();
    EXPECT_THROW(MindlinEngine(op, 1.01 * bound), std::invalid_argument);
    // Set by the shear wave (k ~ h / c_s) and the thickness-shear frequency,
    // not by Kirchhoff's h^2 / (4 kappa): with h < d it is several times longer.
    const double kappa = op->params().material.kappa(0.006);
    EXPECT_GT(bound, 2 * 0.002 * 0.002 / (4 * kappa));
    // and below the 1D shear-wave CFL limit h / c_s of a single direction.
    const double cs = std::sqrt(op->shear_stiffness() / (op->params().material.density_kg_m3 * 0.006));
    EXPECT_LT(bound, 0.002 / cs);
    // Refused: free edges (not implemented) and loss.
    PlateParams p = op->params();
    p.edges.top = EdgeKind::free;
    EXPECT_THROW(MindlinOperator(p, op->grid()), std::invalid_argument);
    p = op->params();
    p.loss = Loss{1.0, 0.0};
    EXPECT_THROW(MindlinOperator(p, op->grid()), std::invalid_argument);
}
