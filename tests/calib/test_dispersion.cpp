// Lamb-wave dispersion against independent truth: series expansions of the
// Rayleigh-Lamb relation derived by hand (checked with sympy, from the
// textbook tan form), a separate long-double root finder on the tanh form of
// the antisymmetric relation, the Rayleigh cubic solved by Eigen's polynomial
// solver, analytic cut-offs, finite differences of k(omega), and the seed's
// wavelengths.
#include "app/commands.h"
#include "physics/dispersion.h"
#include "physics/material.h"

#include <gtest/gtest.h>
#include <unsupported/Eigen/Polynomials>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include <unistd.h>

using namespace calib::physics;

namespace {

constexpr double pi = std::numbers::pi;

#ifdef HAPTIC_ASAN
constexpr int sweep_points = 150;
#else
constexpr int sweep_points = 1000;
#endif

// Table I (E, nu, rho) and three more solids across the range of nu.
std::vector<Material> consistent_materials()
{
    std::vector<Material> out = builtin_materials();
    out.push_back(material_from_elastic(2700, 70e9, 0.33, "aluminium"));
    out.push_back(material_from_elastic(1000, 1e9, 0.45, "nearly-incompressible"));
    out.push_back(material_from_elastic(1000, 1e9, -0.3, "auxetic"));
    return out;
}

// (c_T/c_L)^2 from Lame's constants, not from the library's speeds.
double r_of(const Material &m)
{
    const double nu = m.poisson, lambda_over_mu = 2 * nu / (1 - 2 * nu);
    return 1 / (lambda_over_mu + 2);
}

double shear_speed(const Material &m) { return std::sqrt(m.youngs_pa / (2 * (1 + m.poisson) * m.density_kg_m3)); }

// Rayleigh speed from xi^3 - 8 xi^2 + (24 - 16 r) xi - 16 (1 - r) = 0,
// xi = (c/c_T)^2, the root in (0, 1).
double rayleigh_from_cubic(const Material &m)
{
    const double r = r_of(m);
    Eigen::Vector4d coeffs(-16 * (1 - r), 24 - 16 * r, -8, 1); // ascending powers
    Eigen::PolynomialSolver<double, 3> solver;
    solver.compute(coeffs);
    std::vector<double> roots;
    solver.realRoots(roots);
    double xi = NAN;
    for (double t : roots)
        if (t > 0 && t < 1)
            xi = t;
    return shear_speed(m) * std::sqrt(xi);
}

int count_below(const std::vector<double> &cutoffs, double f)
{
    int n = 0;
    for (double c : cutoffs)
        n += c < f;
    return n;
}

} // namespace

TEST(Dispersion, A0TendsToKirchhoffWithTheHandDerivedCorrection)
{
    // Expanding the antisymmetric relation in k h gives, at fixed omega,
    //   c^2 = c_K^2 sqrt(1 - beta (kh)^2),  beta = 9/5 - (4/3)(c_T/c_L)^2,
    // so c_K/c - 1 -> beta (kh)^2 / 4. Checked down to f*d = 1e-6 Hz*m,
    // where the naive form of the relation has no correct digit left.
    for (const Material &m : consistent_materials()) {
        const double beta = 9.0 / 5 - 4.0 / 3 * r_of(m);
        for (double fd : {1e-3, 1e-4, 1e-6}) {
            const double d = 0.002, f = fd / d;
            const ModePoint a0 = a0_mode(m, d, f);
            const double kh = a0.wavenumber_rad_m * d / 2;
            const double err = kirchhoff_phase_velocity(m, d, f) / a0.phase_velocity_m_s - 1;
            EXPECT_NEAR(err / (kh * kh / 4), beta, 1e-4 * beta) << m.name << " f*d=" << fd;
            EXPECT_NEAR(a0.group_velocity_m_s / a0.phase_velocity_m_s, 2.0, 1e-5) << m.name << " f*d=" << fd;
        }
    }
}

TEST(Dispersion, S0TendsToThePlateSpeedWithLovesCorrection)
{
    // Symmetric relation: c^2 = c_P^2 (1 - gamma (kh)^2), gamma = nu^2 / (3 (1-nu)^2).
    for (const Material &m : consistent_materials()) {
        const double nu = m.poisson, gamma = nu * nu / (3 * (1 - nu) * (1 - nu));
        const double cp = std::sqrt(m.youngs_pa / (m.density_kg_m3 * (1 - nu * nu)));
        EXPECT_NEAR(plate_speed(m) / cp, 1.0, 1e-12) << m.name;
        for (double fd : {1e-1, 1e-2}) {
            const double d = 0.002, f = fd / d;
            const ModePoint s0 = s0_mode(m, d, f);
            const double kh = s0.wavenumber_rad_m * d / 2;
            if (gamma > 1e-3) {
                EXPECT_NEAR((cp / s0.phase_velocity_m_s - 1) / (kh * kh / 2), gamma, 2e-3 * gamma) << m.name;
            }
            EXPECT_NEAR(s0.phase_velocity_m_s / cp, 1.0, gamma * kh * kh + 1e-12) << m.name;
        }
    }
}

TEST(Dispersion, A0MeetsKirchhoffToSecondOrder)
{
    // docs/dispersion.md derives, at fixed omega, with e = (k_K h)^2 the
    // Kirchhoff wavenumber k_K = sqrt(omega / kappa) and r = (c_T/c_L)^2,
    //   c_A0 / c_K - 1 = A1 e + A2 e^2 + O(e^3),
    //   A1 = (20 r - 27) / 60,  A2 = (1680 r^2 - 13160 r + 11559) / 50400.
    // The exact solver must follow the first term with a remainder that is
    // the second term (to O(e^3)), with no constant floor: a material whose
    // exact modes and plate theory used different constants would fail here
    // at every f*d.
    for (const Material &m : consistent_materials()) {
        const double r = r_of(m);
        const double A1 = (20 * r - 27) / 60, A2 = (1680 * r * r - 13160 * r + 11559) / 50400;
        const double d = 0.002, h = d / 2;
        double prev_third = NAN;
        for (double e : {4e-3, 1e-3, 2.5e-4}) {
            // f from e: k_K h = sqrt(e)  =>  omega = kappa e / h^2.
            const double f = m.kappa(d) * e / (h * h) / (2 * pi);
            const double rel = a0_phase_velocity(m, d, f) / kirchhoff_phase_velocity(m, d, f) - 1;
            EXPECT_NEAR((rel - A1 * e) / (A2 * e * e), 1.0, 40 * e) << m.name << " e=" << e;
            const double third = (rel - A1 * e - A2 * e * e) / (e * e * e);
            if (!std::isnan(prev_third)) { // the remainder is O(e^3): a constant to O(e)
                EXPECT_NEAR(third / prev_third, 1.0, 0.05) << m.name << " e=" << e;
            }
            prev_third = third;
        }
    }
}

namespace {

// Antisymmetric Rayleigh-Lamb relation where A0 lives (c < c_T: p = i p',
// q = i q', both imaginary), divided by cosh(p'h) cosh(q'h):
//   (k^2 + q'^2)^2 tanh(p'h) - 4 k^2 p' q' tanh(q'h) = 0,
//   p'^2 = k^2 - omega^2/c_L^2,  q'^2 = k^2 - omega^2/c_T^2.
// Positive just above k = omega/c_T, negative at large k. Long double, with
// c_L, c_T from Lame's constants: nothing is shared with the library.
struct LongDoubleA0 {
    long double omega, h, cl, ct;

    LongDoubleA0(const Material &m, double d, double f)
    {
        const long double E = m.youngs_pa, nu = m.poisson, rho = m.density_kg_m3;
        const long double mu = E / (2 * (1 + nu)), lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
        cl = std::sqrt((lambda + 2 * mu) / rho);
        ct = std::sqrt(mu / rho);
        omega = 2 * std::numbers::pi_v<long double> * f;
        h = d / 2.0L;
    }
    long double operator()(long double k) const
    {
        const long double pp = std::sqrt(k * k - (omega / cl) * (omega / cl));
        const long double qq = std::sqrt(k * k - (omega / ct) * (omega / ct));
        const long double s = k * k + qq * qq;
        return s * s * std::tanh(pp * h) - 4 * k * k * pp * qq * std::tanh(qq * h);
    }
    long double root() const
    {
        long double lo = omega / ct * (1 + 1e-12L), hi = 2 * lo;
        while ((*this)(hi) > 0)
            hi *= 2;
        for (int i = 0; i < 200 && hi - lo > 1e-16L * hi; ++i) {
            const long double mid = (lo + hi) / 2;
            ((*this)(mid) > 0 ? lo : hi) = mid;
        }
        return (lo + hi) / 2;
    }
};

} // namespace

TEST(Dispersion, RayleighSpeedMatchesTheCubic)
{
    for (const Material &m : consistent_materials())
        EXPECT_NEAR(rayleigh_speed(m) / rayleigh_from_cubic(m), 1.0, 1e-13) << m.name;
}

TEST(Dispersion, A0AndS0TendToTheRayleighSpeedAndSH0IsTheShearSpeed)
{
    for (const Material &m : consistent_materials()) {
        const double cr = rayleigh_from_cubic(m), d = 0.002;
        // omega h / c_T = 40: A0 and S0 differ from c_R by ~exp(-2 kh sqrt(1 - (c_R/c_T)^2)).
        const double f_high = 40 * m.ct_m_s() / (pi * d);
        EXPECT_NEAR(a0_phase_velocity(m, d, f_high) / cr, 1.0, 1e-9) << m.name;
        EXPECT_NEAR(s0_mode(m, d, f_high).phase_velocity_m_s / cr, 1.0, 1e-9) << m.name;
        EXPECT_NEAR(a0_group_velocity(m, d, f_high) / cr, 1.0, 1e-8) << m.name;
        // On the way, A0 approaches from below and S0 from above.
        const double f_mid = 2 * m.ct_m_s() / (pi * d);
        EXPECT_LT(a0_phase_velocity(m, d, f_mid), cr) << m.name;
        EXPECT_GT(s0_mode(m, d, f_mid).phase_velocity_m_s, cr) << m.name;
        // SH0 is not dispersive: c_T at every f*d (it does not tend to c_R).
        for (double f : {1.0, f_mid, f_high}) {
            const std::vector<ModePoint> sh = solve_family(m, d, f, ModeFamily::shear_horizontal);
            ASSERT_FALSE(sh.empty());
            EXPECT_NEAR(sh[0].phase_velocity_m_s / shear_speed(m), 1.0, 1e-14);
            EXPECT_NEAR(sh[0].group_velocity_m_s / shear_speed(m), 1.0, 1e-14);
        }
    }
}

TEST(Dispersion, HigherModesAppearAtTheAnalyticCutoffs)
{
    // k -> 0 at the cut-offs: A_n at odd multiples of c_T/(2d) and even
    // multiples of c_L/(2d); S_n at even multiples of c_T/(2d) and odd
    // multiples of c_L/(2d); SH_n at n c_T/(2d). Just on one side of each the
    // family has one root more, and that root has k d -> 0. (Which side
    // depends on whether the branch leaves k = 0 forward or backward.)
    const double d = 0.002;
    for (const Material &m : builtin_materials()) {
        const double fT = m.ct_m_s() / (2 * d), fL = m.cl_m_s() / (2 * d);
        for (ModeFamily fam : {ModeFamily::antisymmetric, ModeFamily::symmetric, ModeFamily::shear_horizontal}) {
            std::vector<double> expected;
            for (int n = 1; n <= 8; ++n) {
                const bool odd = n % 2;
                if (fam == ModeFamily::shear_horizontal || (fam == ModeFamily::antisymmetric) == odd)
                    expected.push_back(n * fT);
                if (fam != ModeFamily::shear_horizontal && (fam == ModeFamily::antisymmetric) != odd)
                    expected.push_back(n * fL);
            }
            std::vector<double> from_lib = cutoff_frequencies(m, d, fam, 8 * fT);
            for (double fc : expected) {
                if (fc <= 8 * fT) {
                    EXPECT_TRUE(std::any_of(from_lib.begin(), from_lib.end(),
                                            [&](double c) { return std::abs(c / fc - 1) < 1e-12; }))
                        << m.name << " cut-off " << fc;
                }
            }
            EXPECT_EQ(std::count_if(expected.begin(), expected.end(), [&](double c) { return c <= 8 * fT; }),
                      static_cast<long>(from_lib.size()));
            for (double fc : from_lib) {
                const std::vector<ModePoint> below = solve_family(m, d, fc * (1 - 1e-8), fam);
                const std::vector<ModePoint> above = solve_family(m, d, fc * (1 + 1e-8), fam);
                ASSERT_EQ(std::abs(static_cast<int>(above.size()) - static_cast<int>(below.size())), 1)
                    << m.name << " " << fc << " Hz";
                const bool forward = above.size() > below.size();
                const double k8 = (forward ? above : below).back().wavenumber_rad_m;
                EXPECT_LT(k8 * d, 0.05) << m.name << " " << fc << " Hz";
                // k^2 grows linearly with the distance to the cut-off.
                const double k10 =
                    solve_family(m, d, fc * (1 + (forward ? 1e-10 : -1e-10)), fam).back().wavenumber_rad_m;
                EXPECT_NEAR(k8 / k10, 10.0, 0.05) << m.name << " " << fc << " Hz";
            }
        }
        // The first higher modes by name.
        EXPECT_EQ(solve_family(m, d, fT * (1 - 1e-6), ModeFamily::antisymmetric).size(), 1u) << m.name;
        EXPECT_EQ(solve_family(m, d, fT * (1 + 1e-6), ModeFamily::antisymmetric).size(), 2u) << m.name;
        EXPECT_EQ(solve_family(m, d, fT * (1 + 1e-6), ModeFamily::shear_horizontal).size(), 2u) << m.name;
    }
}

TEST(Dispersion, GroupVelocityMatchesFiniteDifferencesOfK)
{
    const double d = 0.002;
    for (const Material &m : consistent_materials()) {
        const double fT = m.ct_m_s() / (2 * d);
        for (double f : {0.01 * fT, 0.3 * fT, 1.3 * fT, 2.7 * fT, 5.5 * fT}) {
            const std::vector<ModePoint> modes = solve_modes(m, d, f);
            const double df = 1e-5 * f;
            const std::vector<ModePoint> lo = solve_modes(m, d, f - df), hi = solve_modes(m, d, f + df);
            for (const ModePoint &p : modes) {
                auto same = [&](const std::vector<ModePoint> &v) -> const ModePoint * {
                    for (const ModePoint &q : v)
                        if (q.family == p.family && q.order == p.order)
                            return &q;
                    return nullptr;
                };
                const ModePoint *a = same(lo), *b = same(hi);
                if (!a || !b || std::abs(p.group_velocity_m_s) < 1e-3 * m.ct_m_s())
                    continue; // at a cut-off or a zero-group-velocity point
                const double fd_cg = 2 * pi * 2 * df / (b->wavenumber_rad_m - a->wavenumber_rad_m);
                EXPECT_NEAR(p.group_velocity_m_s / fd_cg, 1.0, 1e-6) << m.name << " " << p.name() << " f=" << f;
            }
        }
    }
}

TEST(Dispersion, DenseSweepHasNoNaNAndNoMissedOrSpuriousRoots)
{
    // From f*d = 1e-3 to 1e4 Hz*m. Every cut-off adds one root for good and
    // every zero-group-velocity point adds a pair, so a family always has
    // 1 + (cut-offs below f) + an even number of roots: a missed or spurious
    // root breaks the parity. Phase speeds are finite and positive, energy
    // travels no faster than c_L.
    const double d = 0.002;
    for (const Material &m : builtin_materials())
        for (int i = 0; i < sweep_points; ++i) {
            const double fd = 1e-3 * std::pow(1e7, (i + 0.5) / sweep_points);
            const double f = fd / d;
            for (ModeFamily fam : {ModeFamily::antisymmetric, ModeFamily::symmetric}) {
                const std::vector<ModePoint> v = solve_family(m, d, f, fam);
                const int extra = static_cast<int>(v.size()) - 1 - count_below(cutoff_frequencies(m, d, fam, f), f);
                EXPECT_TRUE(extra >= 0 && extra % 2 == 0) << m.name << " f*d=" << fd << " roots=" << v.size();
                for (const ModePoint &p : v) {
                    ASSERT_TRUE(std::isfinite(p.phase_velocity_m_s) && std::isfinite(p.group_velocity_m_s) &&
                                std::isfinite(p.wavelength_m))
                        << m.name << " " << p.name() << " f*d=" << fd;
                    EXPECT_GT(p.phase_velocity_m_s, 0);
                    EXPECT_LE(std::abs(p.group_velocity_m_s), m.cl_m_s() * (1 + 1e-9)) << m.name << " " << p.name();
                    EXPECT_NEAR(p.wavelength_m * f / p.phase_velocity_m_s, 1.0, 1e-12);
                }
                for (std::size_t k = 1; k < v.size(); ++k) // ranked by increasing phase speed
                    EXPECT_LT(v[k - 1].phase_velocity_m_s, v[k].phase_velocity_m_s);
            }
        }
}

TEST(Dispersion, CharacteristicSeriesAndDirectFormsAgree)
{
    // Where both evaluations are accurate (|a|, |b| ~ 1) they are the same
    // function: value and both partial derivatives.
    using detail::CharForm;
    for (double r : {0.1, 0.2, 0.4, 0.7})
        for (double W2 : {0.3, 0.8, 1.2})
            for (double x : {0.05, 0.4, 0.9, 1.4}) {
                const auto s = detail::lamb_characteristic(ModeFamily::antisymmetric, x, W2, r, CharForm::series);
                const auto d = detail::lamb_characteristic(ModeFamily::antisymmetric, x, W2, r, CharForm::direct);
                const double scale = (W2 + x) * (W2 + x);
                EXPECT_NEAR(s.F, d.F, 1e-14 * scale);
                EXPECT_NEAR(s.dF_dx, d.dF_dx, 1e-13 * scale);
                EXPECT_NEAR(s.dF_dW2, d.dF_dW2, 1e-13 * scale);
            }
}

TEST(Dispersion, SeedWavelengthsAt300HzOn2mm)
{
    // docs/physics.md (Dispersion): ~161 mm acrylic, ~254 mm steel, ~284 mm glass.
    const std::pair<const char *, double> seed[] = {{"acrylic", 0.161}, {"steel", 0.254}, {"glass", 0.284}};
    for (const auto &[name, lambda] : seed) {
        const Material m = *find_material(name);
        EXPECT_NEAR(a0_wavelength(m, 0.002, 300), lambda, 0.001) << name;
        // Kirchhoff: lambda = 2 pi sqrt(kappa / omega), too long by the
        // series of A0MeetsKirchhoffToSecondOrder (below 0.06 % here).
        const double lk = 2 * pi * std::sqrt(m.kappa(0.002) / (2 * pi * 300));
        const double r = r_of(m), e = (pi * 0.002 / lk) * (pi * 0.002 / lk); // (k_K h)^2
        const double c_over_ck = 1 + (20 * r - 27) / 60 * e + (1680 * r * r - 13160 * r + 11559) / 50400 * e * e;
        const double series = 1 / c_over_ck - 1; // c_K / c - 1, to O(e^3)
        const double err = lk / a0_wavelength(m, 0.002, 300) - 1;
        std::printf("[ measured ] Kirchhoff error at 300 Hz, 2 mm, %s: %+.4f %% (series %+.4f %%)\n", name, 100 * err,
                    100 * series);
        EXPECT_NEAR(err, series, 1e-8) << name;
        EXPECT_LT(err, 6e-4) << name;
    }
}

TEST(Dispersion, KirchhoffOnePercentPointAndMindlin)
{
    // docs/physics.md (Where Kirchhoff stops): Kirchhoff over-estimates c by
    // 1 % at f*d = 10.3 kHz*mm (acrylic) and 39.0 kHz*mm (glass). Measured
    // here (printed, not forced; the assertion is only a factor 1.5;
    // docs/dispersion.md has the figures).
    const double claims[] = {10.3, 39.0};
    const char *names[] = {"acrylic", "glass"};
    for (int i = 0; i < 2; ++i) {
        const Material m = *find_material(names[i]);
        auto err = [&](double fd) {
            return kirchhoff_phase_velocity(m, 0.002, fd / 0.002) / a0_phase_velocity(m, 0.002, fd / 0.002) - 1;
        };
        double lo = 0.1, hi = 1000; // Hz*m, err increasing
        for (int it = 0; it < 60; ++it) {
            const double mid = std::sqrt(lo * hi);
            (err(mid) < 0.01 ? lo : hi) = mid;
        }
        std::printf("[ measured ] Kirchhoff error reaches 1 %% at f*d = %.2f kHz*mm for %s (docs/physics.md: %.1f)\n",
                    lo, names[i], claims[i]);
        EXPECT_GT(lo, claims[i] / 1.5);
        EXPECT_LT(lo, claims[i] * 1.5);
        // Mindlin (pi^2/12) stays within 1 % at 10x that f*d, and under Kirchhoff's error everywhere below.
        for (double fd : {0.1 * lo, lo, 10 * lo}) {
            const double f = fd / 0.002, c = a0_phase_velocity(m, 0.002, f);
            const double em = std::abs(mindlin_phase_velocity(m, 0.002, f) / c - 1);
            EXPECT_LT(em, 0.01) << names[i] << " f*d=" << fd;
            EXPECT_LT(em, std::abs(err(fd)) / 5) << names[i] << " f*d=" << fd;
        }
    }
}

TEST(Dispersion, MindlinLimits)
{
    const double d = 0.002;
    for (const Material &m : consistent_materials()) {
        // Low f*d (1e-5 Hz*m): Kirchhoff.
        EXPECT_NEAR(mindlin_phase_velocity(m, d, 0.005) / kirchhoff_phase_velocity(m, d, 0.005), 1.0, 1e-7) << m.name;
        EXPECT_NEAR(mindlin_group_velocity(m, d, 0.005) / kirchhoff_group_velocity(m, d, 0.005), 1.0, 1e-7) << m.name;
        // High f*d: sqrt(k_s^2) c_T; with k_s^2 = (c_R/c_T)^2 that is the exact A0 limit.
        const double f = 1e4 * m.ct_m_s() / d;
        EXPECT_NEAR(mindlin_phase_velocity(m, d, f, MindlinShear::rayleigh) / rayleigh_from_cubic(m), 1.0, 1e-4)
            << m.name;
        EXPECT_NEAR(mindlin_phase_velocity(m, d, f) / (pi / std::sqrt(12.0) * shear_speed(m)), 1.0, 1e-4) << m.name;
        // Group velocity vs finite difference of k(omega).
        for (double fm : {1e-3, 0.2, 2.0}) {
            const double f0 = fm * m.ct_m_s() / d, df = 1e-5 * f0;
            const double k1 = 2 * pi * (f0 - df) / mindlin_phase_velocity(m, d, f0 - df);
            const double k2 = 2 * pi * (f0 + df) / mindlin_phase_velocity(m, d, f0 + df);
            EXPECT_NEAR(mindlin_group_velocity(m, d, f0) / (2 * pi * 2 * df / (k2 - k1)), 1.0, 1e-6) << m.name;
        }
    }
}

TEST(Dispersion, RejectsBadInput)
{
    const Material m = *find_material("glass");
    EXPECT_THROW(solve_modes(m, 0.002, 0), std::invalid_argument);
    EXPECT_THROW(solve_modes(m, 0.002, -1), std::invalid_argument);
    EXPECT_THROW(solve_modes(m, 0, 100), std::invalid_argument);
    EXPECT_THROW(solve_modes(m, 0.002, NAN), std::invalid_argument);
    Material bad = m;
    bad.poisson = 0.5;
    EXPECT_THROW(solve_modes(bad, 0.002, 100), std::invalid_argument);
    bad = m;
    bad.density_kg_m3 = 0;
    EXPECT_THROW(a0_mode(bad, 0.002, 100), std::invalid_argument);
    EXPECT_THROW(rayleigh_speed(bad), std::invalid_argument);
}

// ------------------------------------------------------------------ CLI

namespace {

struct CliResult {
    int code;
    std::string out, err;
};

CliResult run_cli(std::vector<std::string> args)
{
    args.insert(args.begin(), {"calibgen", "dispersion"});
    std::vector<char *> argv;
    for (std::string &a : args)
        argv.push_back(a.data());
    CLI::App app{"test"};
    int code = -1;
    calib::app::register_dispersion(app, code);
    testing::internal::CaptureStdout();
    testing::internal::CaptureStderr();
    try {
        app.parse(static_cast<int>(argv.size()), argv.data());
    } catch (const CLI::ParseError &e) {
        code = e.get_exit_code();
    }
    CliResult r{code, testing::internal::GetCapturedStdout(), testing::internal::GetCapturedStderr()};
    return r;
}

std::vector<std::string> lines(const std::string &s)
{
    std::vector<std::string> out;
    std::string cur;
    for (char c : s) {
        if (c == '\n') {
            out.push_back(cur);
            cur.clear();
        } else {
            cur += c;
        }
    }
    if (!cur.empty())
        out.push_back(cur);
    return out;
}

} // namespace

TEST(DispersionCli, RangeGivesOneRowPerModeAndFrequency)
{
    const CliResult r = run_cli({"--material", "acrylic", "--thickness", "0.002", "--freq", "40:300:10"});
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<std::string> l = lines(r.out);
    ASSERT_FALSE(l.empty());
    EXPECT_NE(l[0].find("f_hz,mode,phase_velocity_m_s,group_velocity_m_s,wavelength_m"), std::string::npos);
    EXPECT_NE(l[0].find("kirchhoff_phase_velocity_m_s"), std::string::npos);
    EXPECT_NE(l[0].find("mindlin_phase_velocity_m_s"), std::string::npos);
    EXPECT_EQ(l.size(), 1u + 27 * 3); // 40..300 step 10 inclusive; A0, S0, SH0 only below 300 kHz
    // The 300 Hz A0 row: the seed's 161 mm.
    bool found = false;
    for (const std::string &row : l)
        if (row.rfind("300,A0,", 0) == 0) {
            found = true;
            double f, c, cg, lambda;
            ASSERT_EQ(std::sscanf(row.c_str(), "%lf,A0,%lf,%lf,%lf", &f, &c, &cg, &lambda), 4);
            EXPECT_NEAR(lambda, 0.161, 0.001);
        }
    EXPECT_TRUE(found);
}

TEST(DispersionCli, ListCustomMaterialsAndModeFilter)
{
    const CliResult glass =
        run_cli({"--material", "glass", "--thickness", "0.002", "--freq", "300,100", "--modes", "a0"});
    const CliResult elastic = run_cli({"--density", "1590", "--youngs", "68.9e9", "--poisson", "0.16", "--thickness",
                                       "0.002", "--freq", "300,100", "--modes", "A0"});
    // The speeds glass's E, nu, rho imply, to 17 digits: the same solid.
    const Material g = *find_material("glass");
    char cl[32], ct[32];
    std::snprintf(cl, sizeof cl, "%.17g", g.cl_m_s());
    std::snprintf(ct, sizeof ct, "%.17g", g.ct_m_s());
    const CliResult speeds = run_cli(
        {"--density", "1590", "--cl", cl, "--ct", ct, "--thickness", "0.002", "--freq", "300,100", "--modes", "a0"});
    // Table I's printed speeds are another solid: its A0 is 1.9e-4 slower.
    const CliResult printed = run_cli({"--density", "1590", "--cl", "6790", "--ct", "4321", "--thickness", "0.002",
                                       "--freq", "300,100", "--modes", "a0"});
    for (const CliResult *r : {&glass, &elastic, &speeds, &printed})
        ASSERT_EQ(r->code, 0) << r->err;
    ASSERT_EQ(lines(glass.out).size(), 3u);
    auto first5 = [](const std::string &s) {
        std::size_t at = 0;
        for (int k = 0; k < 5; ++k)
            at = s.find(',', at) + 1;
        return s.substr(0, at);
    };
    auto phase = [](const std::string &s) {
        double f = 0, c = 0;
        EXPECT_EQ(std::sscanf(s.c_str(), "%lf,A0,%lf", &f, &c), 2) << s;
        return c;
    };
    for (std::size_t i = 1; i < 3; ++i) {
        const std::string a = lines(glass.out)[i];
        EXPECT_EQ(first5(a), first5(lines(elastic.out)[i]));
        EXPECT_NEAR(phase(lines(speeds.out)[i]) / phase(a), 1.0, 1e-8);
        EXPECT_NEAR(phase(lines(printed.out)[i]) / phase(a) - 1, -1.9e-4, 0.1e-4);
    }
}

TEST(DispersionCli, BadInputIsOneLineNamingTheOption)
{
    struct Case {
        std::vector<std::string> args;
        std::string needle;
    };
    const Case cases[] = {
        {{"--material", "unobtainium", "--thickness", "0.002", "--freq", "100"}, "acrylic, glass, steel"},
        {{"--material", "glass", "--thickness", "0.002", "--freq", "300:40:10"}, "--freq"},
        {{"--material", "glass", "--thickness", "0.002", "--freq", "abc"}, "--freq"},
        {{"--material", "glass", "--thickness", "0.002", "--freq", "10,-5"}, "--freq"},
        {{"--material", "glass", "--thickness", "-1", "--freq", "100"}, "--thickness"},
        {{"--material", "glass", "--thickness", "0.002", "--freq", "100", "--modes", "b7"}, "--modes"},
        {{"--material", "glass", "--density", "1000", "--thickness", "0.002", "--freq", "100"}, "--material"},
        {{"--density", "1000", "--cl", "1000", "--ct", "900", "--thickness", "0.002", "--freq", "100"}, "--cl/--ct"},
        {{"--material", "glass", "--thickness", "0.002", "--freq", "100", "--plot", "x.gif"}, "--plot"},
    };
    for (const Case &c : cases) {
        const CliResult r = run_cli(c.args);
        EXPECT_NE(r.code, 0) << c.needle;
        EXPECT_TRUE(r.out.empty()) << c.needle;
        EXPECT_EQ(lines(r.err).size(), 1u) << r.err;
        EXPECT_NE(r.err.find(c.needle), std::string::npos) << r.err;
    }
}

TEST(DispersionCli, PlotFileIsWritten)
{
    const std::filesystem::path dir =
        std::filesystem::temp_directory_path() / ("test_dispersion_plot_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    for (const char *name : {"d.svg", "d.png"}) {
        const std::string path = (dir / name).string();
        std::filesystem::remove(path);
        const CliResult r = run_cli({"--material", "acrylic,glass,steel", "--thickness", "0.002", "--freq",
                                     "10:1000:50", "--modes", "a0", "--plot", path});
        EXPECT_EQ(r.code, 0) << r.err;
        EXPECT_GT(std::filesystem::file_size(path), 1000u) << path;
    }
    std::filesystem::remove_all(dir);
}

TEST(DispersionCli, A0AgreesWithAnIndependentLongDoubleSolution)
{
    // Acceptance: from 10 Hz to 200 kHz (d = 2 mm, f*d up to 400 kHz*mm),
    // the A0 wavenumber `calibgen dispersion` prints brackets the root of the
    // tanh form of the antisymmetric relation within 1e-6 relative (the
    // residual changes sign between k (1 - 1e-6) and k (1 + 1e-6)), and a
    // separate long-double bisection of that form agrees to 1e-6.
    const CliResult r = run_cli(
        {"--material", "acrylic,glass,steel", "--thickness", "0.002", "--freq", "10:200000:x1.1", "--modes", "a0"});
    const CliResult top =
        run_cli({"--material", "acrylic,glass,steel", "--thickness", "0.002", "--freq", "200000", "--modes", "a0"});
    ASSERT_EQ(r.code, 0) << r.err;
    ASSERT_EQ(top.code, 0) << top.err;
    std::vector<std::string> l = lines(r.out);
    const std::vector<std::string> l_top = lines(top.out);
    l.insert(l.end(), l_top.begin() + 1, l_top.end());
    int rows = 0;
    double worst = 0;
    for (std::size_t i = 1; i < l.size(); ++i) {
        double f = 0, c = 0, cg = 0, lambda = 0, k = 0;
        char material[32] = {};
        const int n = std::sscanf(l[i].c_str(), "%lf,A0,%lf,%lf,%lf,%lf,%*[^,],%*[^,],%*[^,],%*[^,],%31s", &f, &c, &cg,
                                  &lambda, &k, material);
        ASSERT_EQ(n, 6) << l[i];
        const LongDoubleA0 exact(*find_material(material), 0.002, f);
        EXPECT_GT(exact(k * (1 - 1e-6L)), 0) << material << " f=" << f;
        EXPECT_LT(exact(k * (1 + 1e-6L)), 0) << material << " f=" << f;
        const double dev = std::abs(static_cast<double>(k / exact.root() - 1));
        EXPECT_LT(dev, 1e-6) << material << " f=" << f;
        worst = std::max(worst, dev);
        ++rows;
    }
    EXPECT_EQ(rows, 3 * (104 + 1)); // 10 Hz * 1.1^n up to 181.6 kHz, and 200 kHz
    std::printf(
        "[ measured ] A0 wavenumber vs long-double tanh form, 10 Hz..200 kHz, 2 mm, 3 materials: max |dk/k| = %.2g\n",
        worst);
}
