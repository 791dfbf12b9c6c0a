// The finger effect against independent results on a simply supported plate,
// whose discrete modes are known in closed form (sin x sin, eigenvalues
// 16 kappa^2 / h^4 (sin^2(p pi / 2 nx) + sin^2(q pi / 2 ny))^2):
// - a point mass / spring shifts the first mode to the root of the exact
//   secular equation of the rank-one loaded system, and by the first-order
//   amount delta omega / omega = -m phi^2 / (2 M_modal) (resp. + s phi^2 / (2 M_modal omega^2));
// - a damper decays the mode at gamma = c phi^2 / (2 M_modal);
// - plate + finger energy is conserved without damper, never grows with it.
#include "engine/effects/finger.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace plate_test;
using calib::engine::effects::FingerExtension;
using calib::engine::effects::FingerSpec;

namespace {

constexpr double pi = std::numbers::pi;
constexpr int nx = 24, ny = 18;
constexpr double h = 0.01;

struct SsPlate {
    std::shared_ptr<PlateOperator> op = make_plate(nx, ny, h, Edges::all(EdgeKind::simply_supported));
    double k = 0.9 * op->max_time_step();
    double rho_d = op->params().material.density_kg_m3 * op->params().thickness_m;
};

double mode_shape(int p, int q, int i, int j) { return std::sin(p * pi * i / nx) * std::sin(q * pi * j / ny); }

double mode_lambda(const SsPlate &s, int p, int q)
{
    const double sx = std::sin(p * pi / (2.0 * nx)), sy = std::sin(q * pi / (2.0 * ny));
    const double kap = s.op->kappa();
    return 16 * kap * kap / std::pow(h, 4) * std::pow(sx * sx + sy * sy, 2);
}

// phi_pq at a point with bilinear weights, for an M-orthonormal mode.
double mode_at(const SsPlate &s, int p, int q, double x, double y)
{
    const double norm = std::sqrt(s.rho_d * h * h * (nx / 2.0) * (ny / 2.0));
    double v = 0;
    for (const auto &nw : s.op->point_weights(x, y)) {
        const int i = int(nw.node % std::size_t(nx + 1)), j = int(nw.node / std::size_t(nx + 1));
        v += nw.weight * mode_shape(p, q, i, j);
    }
    return v / norm;
}

// sin x sin of mode (1,1) (max 1) read at a point with the bilinear weights.
double shape_at(const SsPlate &s, double x, double y)
{
    double v = 0;
    for (const auto &nw : s.op->point_weights(x, y)) {
        const int i = int(nw.node % std::size_t(nx + 1)), j = int(nw.node / std::size_t(nx + 1));
        v += nw.weight * mode_shape(1, 1, i, j);
    }
    return v;
}

// Root near lambda_11 of 1 = (lambda m - s) sum_j phi_j(x0)^2 / (lambda_j - lambda):
// the exact eigenvalue of (K + s e e^T) v = lambda (M + m e e^T) v.
double loaded_lambda(const SsPlate &s, double m, double spring, double x, double y)
{
    const double l1 = mode_lambda(s, 1, 1);
    auto g = [&](double lam) {
        double sum = 0;
        for (int p = 1; p < nx; ++p)
            for (int q = 1; q < ny; ++q) {
                const double ph = mode_at(s, p, q, x, y);
                sum += ph * ph / (mode_lambda(s, p, q) - lam);
            }
        return 1 - (lam * m - spring) * sum;
    };
    // Mass lowers lambda_11 (root in (0, l1)), a spring raises it (root in (l1, l2)).
    double lo = spring > 0 ? l1 * (1 + 1e-12) : 1e-9 * l1,
           hi = spring > 0 ? mode_lambda(s, 2, 1) * (1 - 1e-12) : l1 * (1 - 1e-12);
    double glo = g(lo);
    for (int it = 0; it < 200; ++it) {
        const double mid = 0.5 * (lo + hi);
        const double gm = g(mid);
        if ((gm > 0) == (glo > 0)) {
            lo = mid;
            glo = gm;
        } else {
            hi = mid;
        }
    }
    return 0.5 * (lo + hi);
}

// Starts the plate at rest in mode (1,1), runs, and returns the modal
// coordinate of mode (1,1) per step.
template <typename T = double>
std::vector<double> run_mode(const SsPlate &s, const FingerSpec &f, std::size_t steps,
                             std::vector<double> *energy = nullptr)
{
    PlateEngine<T> eng(s.op, s.k);
    std::vector<double> shape(s.op->grid().node_count());
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i)
            shape[s.op->grid().node(i, j)] = 1e-6 * mode_shape(1, 1, i, j);
    eng.set_state(shape, shape);
    auto ext = std::make_unique<FingerExtension>(eng, f);
    FingerExtension *finger = ext.get();
    eng.add_extension(std::move(ext));
    double norm = 0;
    for (double v : shape)
        norm += v * v;
    std::vector<double> a;
    for (std::size_t n = 0; n < steps; ++n) {
        eng.step();
        const std::vector<double> u = eng.displacement();
        double dot = 0;
        for (std::size_t node = 0; node < u.size(); ++node)
            dot += u[node] * shape[node];
        a.push_back(dot / norm);
        if (energy)
            energy->push_back(eng.energy() + finger->energy());
    }
    return a;
}

// Angular frequency from the zero crossings (linear interpolation; a sine's
// crossings are inflection points, so this is third-order accurate).
double crossing_omega(const std::vector<double> &a, double k)
{
    double first = -1, last = -1;
    int count = 0;
    for (std::size_t n = 1; n < a.size(); ++n)
        if ((a[n - 1] < 0) != (a[n] < 0)) {
            const double t = (double(n) - 1 + a[n - 1] / (a[n - 1] - a[n])) * k;
            if (first < 0)
                first = t;
            else
                ++count;
            last = t;
        }
    return pi * count / (last - first);
}

double omega_of_lambda(double lambda, double k) { return 2 / k * std::asin(k * std::sqrt(lambda) / 2); }

} // namespace

TEST(EffectFinger, PointMassShiftsFirstModeByTheAnalyticAmount)
{
    const SsPlate s;
    const double x0 = 9.3 * h, y0 = 7.6 * h;
    const double modal_mass = s.rho_d * h * h * (nx / 2.0) * (ny / 2.0); // of sin x sin (max 1)
    const double phi0 = shape_at(s, x0, y0);
    const double omega0 = omega_of_lambda(mode_lambda(s, 1, 1), s.k);
    for (double ratio : {0.004, 0.02, 0.1}) { // m phi0^2 / M_modal
        FingerSpec f;
        f.mass_kg = ratio * modal_mass / (phi0 * phi0);
        f.x_m = x0;
        f.y_m = y0;
        const std::size_t period = std::size_t(2 * pi / omega0 / s.k);
        const std::vector<double> a = run_mode(s, f, scaled(40.0 * double(period)));
        const double measured = crossing_omega(a, s.k);
        const double exact = omega_of_lambda(loaded_lambda(s, f.mass_kg, 0, x0, y0), s.k);
        const double first_order = omega0 * (1 - ratio / 2);
        SCOPED_TRACE("mass ratio " + std::to_string(ratio));
        // Against the exact rank-one secular equation: the scheme's own truth.
        EXPECT_NEAR(measured / exact - 1, 0.0, 1e-5 + 3e-4 * ratio);
        // Against the perturbation formula: exact to first order in the ratio.
        EXPECT_NEAR((measured - omega0) / (first_order - omega0), 1.0, 1.5 * ratio + 0.01);
    }
}

TEST(EffectFinger, SpringDamperRaisesAndDampsTheModeAsPredicted)
{
    const SsPlate s;
    const double x0 = 12.5 * h, y0 = 9.0 * h; // between two nodes
    const double modal_mass = s.rho_d * h * h * (nx / 2.0) * (ny / 2.0);
    const double phi0 = shape_at(s, x0, y0);
    const double lambda0 = mode_lambda(s, 1, 1), omega0 = std::sqrt(lambda0);
    FingerSpec f;
    f.x_m = x0;
    f.y_m = y0;
    f.stiffness_n_m = 0.02 * modal_mass * lambda0 / (phi0 * phi0);    // +2 % in lambda, +1 % in omega
    f.damping_n_s_m = 2 * modal_mass * 2e-3 * omega0 / (phi0 * phi0); // gamma = 2e-3 omega0
    const std::size_t period = std::size_t(2 * pi / omega0 / s.k);
    const std::vector<double> a = run_mode(s, f, scaled(40.0 * double(period)));

    // Decay rate from the log of successive positive peaks (least squares).
    std::vector<double> t, lp;
    for (std::size_t n = 1; n + 1 < a.size(); ++n)
        if (a[n] > a[n - 1] && a[n] >= a[n + 1] && a[n] > 0) {
            t.push_back(double(n) * s.k);
            lp.push_back(std::log(a[n]));
        }
    ASSERT_GE(t.size(), 3u);
    double mt = 0, ml = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
        mt += t[i] / double(t.size());
        ml += lp[i] / double(t.size());
    }
    double num = 0, den = 0;
    for (std::size_t i = 0; i < t.size(); ++i) {
        num += (t[i] - mt) * (lp[i] - ml);
        den += (t[i] - mt) * (t[i] - mt);
    }
    const double gamma_measured = -num / den;
    const double gamma_predicted = f.damping_n_s_m * phi0 * phi0 / (2 * modal_mass);
    EXPECT_NEAR(gamma_measured / gamma_predicted, 1.0, 0.03);

    // Frequency: the spring's exact secular root; the damper's shift is
    // second order (omega sqrt(1 - (gamma/omega)^2): 2e-6 here).
    const double measured = crossing_omega(a, s.k);
    const double exact = omega_of_lambda(loaded_lambda(s, 0, f.stiffness_n_m, x0, y0), s.k);
    EXPECT_NEAR(measured / exact - 1, 0.0, 3e-5);
    const double first_order = omega_of_lambda(lambda0 * 1.02, s.k);
    EXPECT_NEAR(measured / first_order - 1, 0.0, 2e-3);
}

TEST(EffectFinger, PlatePlusFingerEnergyConservedWithoutDamperAndNeverGrowsWithIt)
{
    const SsPlate s;
    const double lambda0 = mode_lambda(s, 1, 1);
    const double modal_mass = s.rho_d * h * h * (nx / 2.0) * (ny / 2.0);
    for (double c : {0.0, 5.0}) {
        FingerSpec f;
        f.x_m = 7.3 * h;
        f.y_m = 11.2 * h;
        f.mass_kg = 0.05 * modal_mass;
        f.stiffness_n_m = 0.05 * modal_mass * lambda0;
        f.damping_n_s_m = c;
        std::vector<double> e;
        run_mode(s, f, scaled(20000), &e);
        SCOPED_TRACE("damping " + std::to_string(c));
        if (c == 0) {
            double worst = 0;
            for (double v : e)
                worst = std::max(worst, std::abs(v / e.front() - 1));
            EXPECT_LT(worst, 1e-11);
        } else {
            for (std::size_t n = 1; n < e.size(); ++n)
                ASSERT_LE(e[n], e[n - 1] * (1 + 1e-13)) << "step " << n;
            EXPECT_LT(e.back(), 0.9 * e.front());
        }
    }
}

TEST(EffectFinger, RefusesBadInput)
{
    const SsPlate s;
    PlateEngine<double> eng(s.op, s.k);
    FingerSpec f;
    f.x_m = 0.05;
    f.y_m = 0.05;
    f.mass_kg = -1;
    EXPECT_THROW(FingerExtension(eng, f), std::invalid_argument);
    f.mass_kg = 0.001;
    f.stiffness_n_m = 1e12; // far beyond what the time step allows
    EXPECT_THROW(FingerExtension(eng, f), std::invalid_argument);
    f.stiffness_n_m = 0;
    f.x_m = 1.0; // off the plate
    EXPECT_THROW(FingerExtension(eng, f), std::invalid_argument);
    f.x_m = 0; // on the held edge only
    EXPECT_THROW(FingerExtension(eng, f), std::invalid_argument);
}
