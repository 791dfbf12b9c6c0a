// The ideal-focus ceiling against closed forms: a long burst is nearly
// monochromatic, so its ring beyond lambda/2 tends to J0's first extremum,
// |J0(3.8317)| = 0.40276 (-7.90 dB), at 0.61 lambda; a short pulse spreads
// its rings and scores higher (a second evaluation gives the Fig. 7 figure);
// on a non-dispersive plate (k = 2 pi f / c) the ceiling does not depend on
// c (the field scales with r / c).
#include "pipeline/verification/focus_ceiling.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <numbers>
#include <vector>

using namespace calib::pipeline;

namespace {
// A0 of 2 mm PMMA (E 4.76 GPa, rho 1200 kg/m^3, nu 0.38): k = (omega^2 rho h / D)^(1/4).
double a0_k(double f)
{
    const double h = 0.002, rho = 1200, E = 4.76e9, nu = 0.38;
    const double D = E * h * h * h / (12 * (1 - nu * nu));
    const double w = 2 * std::numbers::pi * f;
    return std::pow(w * w * rho * h / D, 0.25);
}
} // namespace

TEST(FocusCeiling, LongBurstTendsToTheFirstExtremumOfJ0)
{
    PulseSpec p;
    p.centre_hz = 300;
    p.cycles = 40;
    const double lambda = 2 * std::numbers::pi / a0_k(300);
    const FocusCeiling c = ideal_focus_ceiling(p, a0_k, lambda / 2);
    const double j0_db = -20 * std::log10(0.402759);
    EXPECT_NEAR(c.target_db, j0_db, 0.15);
    EXPECT_NEAR(c.autocorrelation_db, j0_db, 0.15);
    EXPECT_NEAR(c.target_ring_radius_m / lambda, 3.8317 / (2 * std::numbers::pi), 0.02);
}

TEST(FocusCeiling, ShortPulseScoresAboveTheMonochromaticRing)
{
    PulseSpec p; // the seed's 2-cycle Hann burst at 300 Hz
    const double lambda = 2 * std::numbers::pi / a0_k(300);
    const FocusCeiling c = ideal_focus_ceiling(p, a0_k, lambda / 2);
    // A second evaluation (direct sums over 5 Hz bins to 1.5 kHz, J0 by its
    // integral (1/pi) int cos(x sin th) dth, radii every 4 mm) gave 9.85 dB
    // and 9.45 dB, the ring at 97 mm = 0.60 lambda.
    EXPECT_NEAR(c.target_db, 9.85, 0.1);
    EXPECT_NEAR(c.autocorrelation_db, 9.45, 0.1);
    EXPECT_NEAR(c.target_ring_radius_m / lambda, 0.60, 0.03);
}

TEST(FocusCeiling, NonDispersivePlateScalesWithTheSpeed)
{
    PulseSpec p;
    for (double c0 : {50.0, 400.0}) {
        auto k = [c0](double f) { return 2 * std::numbers::pi * f / c0; };
        const double lambda = c0 / 300;
        const FocusCeiling c = ideal_focus_ceiling(p, k, lambda / 2);
        static double first = c.target_db;
        EXPECT_NEAR(c.target_db, first, 1e-6);
        // Without dispersion the pulse's low frequencies keep the main lobe
        // wide: the largest |w| beyond lambda/2 is its flank at lambda/2.
        EXPECT_NEAR(c.target_ring_radius_m / lambda, 0.5, 1e-9);
    }
    EXPECT_THROW(ideal_focus_ceiling(p, a0_k, 0.0), std::invalid_argument);
}

// The ceiling is a bound for every field that puts the pulse at the focus.
// Around the focus, in a region free of sources and far (in wavelengths)
// from the edges, the field at each frequency is sum_n a_n J_n(k r) e^{i n th}
// (the evanescent I_n terms have decayed). At r = 0 only J0 is non-zero, so
// the pulse at the focus fixes a_0 = S: the ideal focus. The mean of w over
// the circle of radius r is that J0 term, and a maximum is never below a
// mean: at every r and t, max over th of |w| >= |w_ideal(r, t)|. Checked here
// by direct sums (the pulse's DFT by hand, J_n from the standard library)
// for fields with random J_1..J_4 content added: none scores above the
// ideal focus, and the ideal one matches ideal_focus_ceiling.
TEST(FocusCeiling, NoFieldWithThePulseAtTheFocusScoresAboveIt)
{
    PulseSpec p; // the seed's pulse
    const double lambda = 2 * std::numbers::pi / a0_k(300);
    const double ceiling = ideal_focus_ceiling(p, a0_k, lambda / 2).target_db;
    // The pulse's spectrum on a 12.5 Hz grid (an 80 ms period) to 1.2 kHz,
    // centred on t = 0.
    const double rate = 9600, df = 12.5;
    const std::vector<double> x = sample_pulse(p, rate);
    const double t0 = pulse_duration_s(p) / 2;
    const std::size_t B = 96;
    std::vector<std::complex<double>> S(B);
    std::vector<double> k(B);
    for (std::size_t b = 1; b < B; b++) {
        const double w = 2 * std::numbers::pi * df * double(b);
        for (std::size_t n = 0; n < x.size(); n++)
            S[b] += x[n] * std::exp(std::complex<double>(0, -w * (double(n) / rate - t0))) / rate;
        k[b] = a0_k(df * double(b));
    }
    // Times within +-20 ms of the focal instant, every 0.1 ms.
    std::vector<std::vector<std::complex<double>>> phase(401, std::vector<std::complex<double>>(B));
    for (std::size_t i = 0; i < phase.size(); i++)
        for (std::size_t b = 1; b < B; b++)
            phase[i][b] =
                std::exp(std::complex<double>(0, 2 * std::numbers::pi * df * double(b) * (double(i) - 200.0) * 1e-4));
    auto largest = [&](const std::vector<std::complex<double>> &A) {
        double m = 0;
        for (const auto &ph : phase) {
            double w = 0;
            for (std::size_t b = 1; b < B; b++)
                w += 2 * df * (A[b] * ph[b]).real();
            m = std::max(m, std::abs(w));
        }
        return m;
    };
    const double focal = largest(S);
    // Random J_1..J_4 content per frequency, seeded; strength 0 is the ideal focus.
    uint32_t seed = 12345;
    auto uniform = [&seed] {
        seed = seed * 1664525u + 1013904223u;
        return double(seed >> 8) / double(1u << 24);
    };
    std::vector<std::vector<std::complex<double>>> a(5, std::vector<std::complex<double>>(B));
    for (std::size_t n = 1; n <= 4; n++)
        for (std::size_t b = 1; b < B; b++)
            a[n][b] = std::polar(uniform(), 2 * std::numbers::pi * uniform());
    double ideal_db = 0;
    for (double strength : {0.0, 0.3, 1.0}) {
        double worst = 0;
        std::vector<std::complex<double>> A(B);
        for (double r = lambda / 2; r <= 2 * lambda; r += lambda / 50)
            for (int th = 0; th < (strength == 0 ? 1 : 24); th++) {
                const double angle = 2 * std::numbers::pi * th / 24;
                for (std::size_t b = 1; b < B; b++) {
                    std::complex<double> g = std::cyl_bessel_j(0.0, k[b] * r);
                    for (std::size_t n = 1; n <= 4; n++)
                        g += strength * a[n][b] * std::cyl_bessel_j(double(n), k[b] * r) *
                             std::exp(std::complex<double>(0, double(n) * angle));
                    A[b] = S[b] * g;
                }
                worst = std::max(worst, largest(A));
            }
        const double db = 20 * std::log10(focal / worst);
        if (strength == 0) {
            ideal_db = db;
            EXPECT_NEAR(db, ceiling, 0.1);
        } else {
            EXPECT_LE(db, ideal_db + 1e-9) << "strength " << strength;
            // Not vacuous: the maximum over a circle is above its mean when
            // the field varies around it (9.00 and 7.30 dB against 9.81 for
            // this seed).
            EXPECT_LT(db, ideal_db - 0.3) << "strength " << strength;
            EXPECT_NEAR(db, strength < 0.5 ? 9.00 : 7.30, 0.05) << "strength " << strength;
        }
    }
}
