// Conservation laws of the scheme: the discrete energy is constant to
// round-off without loss for every combination of edges, never increases with
// loss, and the loss decays modes at the rate the T60 values ask for.
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace plate_test;

TEST(PlateEnergy, LosslessEnergyIsConservedForEveryEdgeCombination)
{
    // 81 combinations on a 12 x 10 grid (a 9 x 7 bulk plus the edge band),
    // 1e5 steps each at 0.95 of the bound, from a random displacement at
    // rest (a random velocity would also set plates with free edges drifting
    // as rigid bodies, whose growing displacement only adds round-off).
    const std::size_t steps = scaled(1e5);
    for (const Edges &e : all_edge_combinations()) {
        auto op = make_plate(12, 10, 0.01, e);
        PlateEngine<double> eng(op, 0.95 * op->max_time_step());
        eng.set_state(random_field(*op, 1), random_field(*op, 1));
        const double e0 = eng.energy();
        ASSERT_GT(e0, 0);
        double worst = 0;
        for (std::size_t n = 0; n < steps; ++n) {
            eng.step();
            if (n % 10000 == 9999 || n + 1 == steps)
                worst = std::max(worst, std::abs(eng.energy() / e0 - 1));
        }
        EXPECT_LE(worst, 1e-12) << describe(e);
    }
}

TEST(PlateEnergy, FloatRunStaysCloseToConserved)
{
    // float32: the same scheme, energy drift stays at the float round-off level.
    auto op = make_plate(40, 30, 0.01, {EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported});
    PlateEngine<float> eng(op, 0.95 * op->max_time_step());
    eng.set_state(random_field(*op, 3), random_field(*op, 4));
    const double e0 = eng.energy();
    ScopedFlushDenormals ftz;
    for (std::size_t n = 0; n < scaled(2e4); ++n)
        eng.step();
    EXPECT_LE(std::abs(eng.energy() / e0 - 1), 1e-4);
}

TEST(PlateEnergy, LossyEnergyNeverIncreases)
{
    const Loss loss{2.0, 1e-3}; // sigma0 (1/s), sigma1 (m^2/s): strong, to see it act
    for (const Edges &e : {Edges::all(EdgeKind::clamped), Edges::all(EdgeKind::free),
                           Edges{EdgeKind::free, EdgeKind::simply_supported, EdgeKind::free, EdgeKind::clamped}}) {
        auto op = make_plate(14, 11, 0.01, e, 0.3, loss);
        PlateEngine<double> eng(op, 0.95 * op->max_time_step());
        eng.set_state(random_field(*op, 5), random_field(*op, 6));
        double prev = eng.energy();
        const double e0 = prev;
        for (std::size_t n = 0; n < scaled(20000); ++n) {
            eng.step();
            const double now = eng.energy();
            ASSERT_LE(now, prev * (1 + 1e-13)) << describe(e) << " step " << n;
            prev = now;
        }
        EXPECT_LT(prev, 0.5 * e0) << describe(e); // and the loss really acts
    }
}

TEST(PlateEnergy, LossDecaysModesAtTheRequestedT60)
{
    // Simply supported plate, sine modes (1,1) and (3,2); the T60 values are
    // asked at their frequencies. The amplitude s of a pure mode obeys
    // s+ = A s + B s-, and |z|^2 = -B is the per-step decay of the amplitude
    // squared, so the measured T60 = 3 ln(10) / (-ln(-B) / (2k)).
    using std::numbers::pi;
    const int nx = 40, ny = 30;
    const double h = 0.0125, a = nx * h, b = ny * h;
    auto lossless = make_plate(nx, ny, h, Edges::all(EdgeKind::simply_supported));
    const double kappa = lossless->kappa();
    const int modes[2][2] = {{1, 1}, {3, 2}};
    double f[2];
    for (int q = 0; q < 2; ++q)
        f[q] = kappa * (std::pow(modes[q][0] * pi / a, 2) + std::pow(modes[q][1] * pi / b, 2)) / (2 * pi);
    const double t60[2] = {0.08, 0.03};
    const Loss loss = loss_from_t60(kappa, f[0], t60[0], f[1], t60[1]);
    ASSERT_GT(loss.sigma0, 0);
    ASSERT_GT(loss.sigma1, 0);
    auto op = make_plate(nx, ny, h, Edges::all(EdgeKind::simply_supported), 0.3, loss);
    for (int q = 0; q < 2; ++q) {
        const int m = modes[q][0], n = modes[q][1];
        PlateEngine<double> eng(op, 0.9 * op->max_time_step());
        std::vector<double> v(op->grid().node_count());
        double vv = 0;
        for (int j = 0; j <= ny; ++j)
            for (int i = 0; i <= nx; ++i) {
                v[op->grid().node(i, j)] = std::sin(m * pi * i / nx) * std::sin(n * pi * j / ny);
                vv += v[op->grid().node(i, j)] * v[op->grid().node(i, j)];
            }
        eng.set_state(v, v);
        std::vector<double> s{1.0};
        for (int t = 0; t < 600; ++t) {
            eng.step();
            const auto u = eng.displacement();
            double uv = 0;
            for (std::size_t p = 0; p < u.size(); ++p)
                uv += u[p] * v[p];
            s.push_back(uv / vv);
        }
        // Least squares for A, B in s[t+1] = A s[t] + B s[t-1].
        double saa = 0, sab = 0, sbb = 0, ya = 0, yb = 0;
        for (std::size_t t = 1; t + 1 < s.size(); ++t) {
            saa += s[t] * s[t];
            sab += s[t] * s[t - 1];
            sbb += s[t - 1] * s[t - 1];
            ya += s[t + 1] * s[t];
            yb += s[t + 1] * s[t - 1];
        }
        const double det = saa * sbb - sab * sab;
        const double B = (saa * yb - sab * ya) / det;
        const double rate = -std::log(-B) / (2 * eng.time_step());
        const double measured_t60 = 3 * std::log(10.0) / rate;
        EXPECT_NEAR(measured_t60 / t60[q], 1.0, 0.01) << "mode " << m << "," << n << " at " << f[q] << " Hz";
    }
}

TEST(PlateEnergy, LossFitTakesAnExactOneOverFLawAtEveryThickness)
{
    // A constant loss factor: T60 proportional to 1/f, so sigma0 = 0 exactly.
    // The fit must accept it whatever the plate's kappa (round-off in the
    // subtraction once refused it at 3 mm of acrylic), and must still refuse a
    // law that falls faster than 1/f by a part in a million.
    int accepted = 0;
    for (int i = 0; i < 200; i++) {
        const double kappa = 0.05 * std::pow(1.03, i); // 0.05 ... 18 m^2/s
        const Loss l = loss_from_t60(kappa, 100, 0.54, 300, 0.18);
        EXPECT_GE(l.sigma0, 0.0) << "kappa " << kappa;
        EXPECT_LT(l.sigma0, 1e-12 * 3 * std::log(10.0) / 0.54) << "kappa " << kappa;
        // sigma1 xi = the decay rate at each frequency: 3 ln 10 / T60.
        EXPECT_NEAR(l.sigma1 * 2 * std::numbers::pi * 300 / kappa, 3 * std::log(10.0) / 0.18, 1e-9);
        EXPECT_THROW(loss_from_t60(kappa, 100, 0.54, 300, 0.18 * (1 - 1e-6)), std::invalid_argument);
        accepted++;
    }
    EXPECT_EQ(accepted, 200);
}

TEST(PlateEnergy, LossFitRefusesGrowingT60)
{
    EXPECT_THROW(loss_from_t60(1.0, 100, 0.1, 1000, 0.2), std::invalid_argument);
    EXPECT_THROW(loss_from_t60(1.0, 100, 0.1, 100, 0.2), std::invalid_argument);
    EXPECT_THROW(loss_from_t60(1.0, 100, -0.1, 1000, 0.2), std::invalid_argument);
    // Equal T60 at both frequencies: pure sigma0 = 3 ln 10 / T60.
    const Loss l = loss_from_t60(1.0, 100, 0.5, 1000, 0.5);
    EXPECT_NEAR(l.sigma0, 3 * std::log(10.0) / 0.5, 1e-12);
    EXPECT_NEAR(l.sigma1, 0.0, 1e-15);
}
