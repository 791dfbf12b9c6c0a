// The exciter effect against independent results:
// - into a (nearly) blocked plate, the delivered force per Bl i equals the
//   analytic second-order high-pass M s^2 / (M s^2 + c s + k) at frequencies
//   below, at and above its resonance (lock-in of the steady state);
// - on a light plate, the force, current and plate motion satisfy the
//   exciter's two-port relation F = T Bl i - Zm W (the coupling is right);
// - |T(f0)| = Q (hand-derived), and pre-compensated signals played through a
//   separately integrated exciter ODE (RK4 on a fine step) give back the
//   wanted force within the band.
#include "engine/effects/exciter.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>

using namespace plate_test;
using namespace calib::engine::effects;

namespace {

constexpr double pi = std::numbers::pi;
using cd = std::complex<double>;

ExciterSpec ex60_like()
{
    // ~EX60 class: 300 Hz resonance, Q = 2, 30 g moving magnet.
    ExciterSpec e;
    e.moving_mass_kg = 0.03;
    e.stiffness_n_m = e.moving_mass_kg * std::pow(2 * pi * 300, 2);
    e.damping_n_s_m = std::sqrt(e.stiffness_n_m * e.moving_mass_kg) / 2;
    e.force_factor_n_a = 3.0;
    return e;
}

// Complex amplitude of x at omega over the last `periods` whole periods.
cd lock_in(const std::vector<double> &x, double omega, double k, int periods, std::size_t offset = 0)
{
    const std::size_t per = std::size_t(std::llround(2 * pi / omega / k));
    const std::size_t len = per * std::size_t(periods);
    cd sum = 0;
    for (std::size_t n = x.size() - len; n < x.size(); ++n)
        sum += x[n] * std::exp(cd(0, -omega * double(n + offset) * k));
    return 2.0 * sum / double(len);
}

struct Driven {
    std::vector<double> current, force, w; // w[n]: plate displacement at the exciter at level n
    double k = 0;
};

// Sine current at f through the exciter on a lossy simply supported plate
// (the loss lets the plate reach its steady state).
Driven drive_sine(double density, double thickness, double f, const ExciterSpec &e, double duration)
{
    Loss loss{100.0, 0.0}; // sigma0 = 100 1/s: transients fall 5e-5 in 0.1 s
    PlateParams p;
    const int nx = 30, ny = 25;
    const double h = 0.01;
    p.size_x_m = nx * h;
    p.size_y_m = ny * h;
    p.thickness_m = thickness;
    p.material = calib::physics::material_from_elastic(density, 70e9, 0.3, "test");
    p.edges = Edges::all(EdgeKind::simply_supported);
    p.loss = loss;
    auto op = std::make_shared<PlateOperator>(p, Grid{nx, ny, h});
    Driven d;
    d.k = std::min(0.9 * op->max_time_step(), 1.0 / (f * 200));
    PlateEngine<double> eng(op, d.k);
    const double x = 0.113, y = 0.087;
    auto ext = std::make_unique<ExciterExtension>(eng, x, y, e);
    ExciterExtension *ex = ext.get();
    eng.add_extension(std::move(ext));
    const std::size_t r = eng.add_receiver(x, y);
    const std::size_t steps = std::size_t(duration / d.k);
    for (std::size_t n = 0; n < steps; ++n)
        d.current.push_back(std::sin(2 * pi * f * double(n) * d.k));
    ex->set_drive(d.current);
    d.w.push_back(0.0); // level 0
    for (std::size_t n = 0; n < steps; ++n) {
        eng.step();
        d.w.push_back(eng.receiver_value(r)); // level n + 1
    }
    d.w.pop_back(); // w[n] = level n, aligned with force[n] and current[n]
    d.force = ex->forces();
    return d;
}

} // namespace

TEST(EffectExciter, TransferPeaksAtResonanceWithGainQ)
{
    const ExciterSpec e = ex60_like();
    EXPECT_NEAR(exciter_resonance_hz(e), 300.0, 1e-9);
    EXPECT_NEAR(exciter_q(e), 2.0, 1e-12);
    // At f0, M s^2 = -k: T = -k / (j c omega0), |T| = Q, phase +90 deg.
    const cd t0 = exciter_transfer(e, 300.0);
    EXPECT_NEAR(std::abs(t0), 2.0, 1e-12);
    EXPECT_NEAR(std::arg(t0), pi / 2, 1e-12);
    // High-pass: -> 1 far above, ~ (f / f0)^2 far below.
    EXPECT_NEAR(std::abs(exciter_transfer(e, 30000.0)), 1.0, 2e-4);
    EXPECT_NEAR(std::abs(exciter_transfer(e, 3.0)), 1e-4, 1e-6);
}

TEST(EffectExciter, BlockedForceFollowsTheSecondOrderTransfer)
{
    const ExciterSpec e = ex60_like();
    // A 10 mm plate 1000x denser than aluminium: the point impedance
    // 8 sqrt(D rho d) is ~1e5 N s/m, ~1000x the exciter's: nearly blocked.
    for (double f : {150.0, 300.0, 600.0}) {
        const Driven d = drive_sine(2.7e6, 0.01, f, e, 0.1);
        const double omega = 2 * pi * f;
        const cd ratio = lock_in(d.force, omega, d.k, 10) / (e.force_factor_n_a * lock_in(d.current, omega, d.k, 10));
        const cd truth = exciter_transfer(e, f);
        SCOPED_TRACE("f = " + std::to_string(f));
        EXPECT_LT(std::abs(ratio - truth) / std::abs(truth), 0.01) << ratio << " vs " << truth;
    }
}

TEST(EffectExciter, CoupledToALightPlateSatisfiesTheTwoPortRelation)
{
    const ExciterSpec e = ex60_like();
    for (double f : {200.0, 450.0}) {
        const Driven d = drive_sine(2700, 0.002, f, e, 0.1);
        const double omega = 2 * pi * f;
        const cd s(0, omega);
        const cd F = lock_in(d.force, omega, d.k, 10), I = lock_in(d.current, omega, d.k, 10),
                 W = lock_in(d.w, omega, d.k, 10);
        const double M = e.moving_mass_kg, c = e.damping_n_s_m, kk = e.stiffness_n_m;
        const cd zm = M * s * s * (c * s + kk) / (M * s * s + c * s + kk);
        const cd predicted = exciter_transfer(e, f) * e.force_factor_n_a * I - zm * W;
        SCOPED_TRACE("f = " + std::to_string(f));
        // The plate's motion must matter here, or this checks nothing.
        EXPECT_GT(std::abs(zm * W) / std::abs(F), 0.05);
        EXPECT_LT(std::abs(F - predicted) / std::abs(F), 0.01) << F << " vs " << predicted;
    }
}

TEST(EffectExciter, PrecompensatedSignalDeliversTheWantedForceInBand)
{
    const ExciterSpec e = ex60_like();
    const double rate = 48000;
    // Wanted force: a 6-cycle Hann burst at 1.2 kHz (band ~ 0.8-1.6 kHz, above the resonance).
    std::vector<double> wanted(4800, 0.0);
    const double fc = 1200, dur = 6 / fc;
    for (std::size_t n = 0; n < wanted.size(); ++n) {
        const double t = double(n) / rate - 0.02;
        if (t >= 0 && t <= dur)
            wanted[n] = std::sin(2 * pi * fc * t) * 0.5 * (1 - std::cos(2 * pi * t / dur));
    }
    const std::vector<double> drive = precompensate(wanted, rate, e); // Bl i
    // Play `drive` through M z'' + c z' + k z = -u(t), F = -M z'' (RK4, 16 substeps, linear u).
    auto play = [&](const std::vector<double> &u) {
        std::vector<double> force(u.size());
        double z = 0, v = 0;
        const int sub = 16;
        const double dt = 1.0 / rate / sub;
        auto acc = [&](double zz, double vv, double uu) {
            return (-e.stiffness_n_m * zz - e.damping_n_s_m * vv - uu) / e.moving_mass_kg;
        };
        for (std::size_t n = 0; n < u.size(); ++n) {
            force[n] = -e.moving_mass_kg * acc(z, v, u[n]);
            const double u0 = u[n], u1 = n + 1 < u.size() ? u[n + 1] : 0.0;
            for (int s = 0; s < sub; ++s) {
                const double a = double(s) / sub, b = double(s + 1) / sub, m = 0.5 * (a + b);
                const double ua = u0 + (u1 - u0) * a, um = u0 + (u1 - u0) * m, ub = u0 + (u1 - u0) * b;
                const double k1z = v, k1v = acc(z, v, ua);
                const double k2z = v + 0.5 * dt * k1v, k2v = acc(z + 0.5 * dt * k1z, v + 0.5 * dt * k1v, um);
                const double k3z = v + 0.5 * dt * k2v, k3v = acc(z + 0.5 * dt * k2z, v + 0.5 * dt * k2v, um);
                const double k4z = v + dt * k3v, k4v = acc(z + dt * k3z, v + dt * k3v, ub);
                z += dt / 6 * (k1z + 2 * k2z + 2 * k3z + k4z);
                v += dt / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
            }
        }
        return force;
    };
    auto rel_error = [&](const std::vector<double> &got) {
        double num = 0, den = 0;
        for (std::size_t n = 0; n < wanted.size(); ++n) {
            num += (got[n] - wanted[n]) * (got[n] - wanted[n]);
            den += wanted[n] * wanted[n];
        }
        return std::sqrt(num / den);
    };
    const double with = rel_error(play(drive));
    const double without = rel_error(play(wanted));
    EXPECT_LT(with, 0.01);
    EXPECT_GT(without, 0.1); // the exciter alone does distort this pulse
}

TEST(EffectExciter, RefusesUnusableParameters)
{
    ExciterSpec e = ex60_like();
    e.moving_mass_kg = 0;
    EXPECT_THROW(check_exciter(e), std::invalid_argument);
    e = ex60_like();
    e.force_factor_n_a = -1;
    EXPECT_THROW(check_exciter(e), std::invalid_argument);
    e = ex60_like();
    e.damping_n_s_m = -1;
    EXPECT_THROW(precompensate({1.0, 2.0}, 48000, e), std::invalid_argument);
}
