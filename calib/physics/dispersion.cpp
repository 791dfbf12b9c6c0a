// Rayleigh-Lamb modes by sign-change bracketing of an entire (pole-free)
// characteristic function, then Brent refinement.
//
// Notation (h = d/2 the half thickness): x = (k h)^2, W2 = (omega h / c_T)^2,
// r = (c_T / c_L)^2, a = (p h)^2 = r W2 - x, b = (q h)^2 = W2 - x. With
// S(z) = sin(sqrt z)/sqrt z and C(z) = cos(sqrt z) (sinh/cosh for z < 0, so
// both are real and entire in z) the classical relations
//   symmetric:      (q^2-k^2)^2 cos(ph) sin(qh) + 4 k^2 p q sin(ph) cos(qh) = 0
//   antisymmetric:  (q^2-k^2)^2 sin(ph) cos(qh) + 4 k^2 p q cos(ph) sin(qh) = 0
// divided by q h (resp. p h) become
//   F_S = (b-x)^2 C(a) S(b) + 4 x a S(a) C(b)
//   F_A = (b-x)^2 S(a) C(b) + 4 x b S(b) C(a)
// which have no poles (every sign change is a root) and no trivial roots at
// p = 0 or q = 0. Both are multiplied by exp(-sqrt(-a) - sqrt(-b)) on the
// evanescent side so nothing overflows at high f*d; the positive factor moves
// no root.
//
// At low f*d the A0 root of F_A comes from a cancellation of O(x^2) terms down
// to O(x^4) (x ~ omega): evaluated as written, F_A keeps only ~1e-5 relative
// precision at f*d = 1e-3 Hz*m. Using (b-x)^2 + 4xb = W2^2,
//   F_A = (b-x)^2 (a-b) G(a,b) + W2^2 S(b) C(a),  G = (S(a)C(b) - S(b)C(a)) / (a-b),
// where a - b = (r-1) W2 is exact and G is summed as a double power series
// (G(0,0) = 1/3); no term cancels any more.
#include "physics/dispersion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace calib::physics {

namespace {

constexpr double pi = std::numbers::pi;

// S, C and their z-derivatives, all multiplied by `scale` = exp(-sqrt(-z))
// for z < 0 (1 otherwise).
struct Trig {
    double S, C, dS, dC, scale;
};

Trig trig(double z)
{
    Trig t{};
    if (z >= 0) {
        const double s = std::sqrt(z);
        t.scale = 1.0;
        t.S = s > 0 ? std::sin(s) / s : 1.0;
        t.C = std::cos(s);
    } else {
        const double s = std::sqrt(-z);
        t.scale = std::exp(-s);
        t.S = s > 0 ? -std::expm1(-2 * s) / (2 * s) : 1.0; // sinh(s) e^-s / s
        t.C = 0.5 * (1.0 + std::exp(-2 * s));              // cosh(s) e^-s
    }
    t.dC = -0.5 * t.S;
    if (std::abs(z) > 0.5) {
        t.dS = (t.C - t.S) / (2 * z);
    } else {
        // dS/dz = -sum_{n>=1} n (-z)^{n-1} / (2n+1)!
        double term = 1.0 / 6.0, sum = 0; // n = 1: 1/3!
        for (int n = 1; n <= 12; ++n) {
            sum += n * term;
            term *= -z / ((2.0 * n + 2) * (2.0 * n + 3));
        }
        t.dS = -sum * t.scale;
    }
    return t;
}

// G(a,b) = (S(a)C(b) - S(b)C(a))/(a-b) = sum g[p][q] A^p B^q, A = -a, B = -b.
// From S(z)C(w) = sum (-z)^m (-w)^n / ((2m+1)! (2n)!) the coefficient of
// A^m B^n in D = S(a)C(b)-S(b)C(a) is 2(n-m)/((2m+1)!(2n+1)!), and
// B^j - A^j = (B - A) sum_i A^i B^{j-1-i} with B - A = a - b.
constexpr int g_degree = 16;
using GTable = std::array<std::array<double, g_degree + 1>, g_degree + 1>;

const GTable &g_coefficients()
{
    static const GTable table = [] {
        GTable g{};
        std::array<double, 2 * g_degree + 4> fact{};
        fact[0] = 1;
        for (std::size_t i = 1; i < fact.size(); ++i)
            fact[i] = fact[i - 1] * static_cast<double>(i);
        for (int m = 0; m <= g_degree; ++m)
            for (int n = m + 1; m + n - 1 <= g_degree; ++n) {
                const double c = 2.0 * (n - m) / (fact[2 * m + 1] * fact[2 * n + 1]);
                for (int i = 0; i < n - m; ++i)
                    g[m + i][n - 1 - i] += c;
            }
        return g;
    }();
    return table;
}

struct GValue {
    double G, dG_da, dG_db;
};

GValue g_series(double a, double b)
{
    const GTable &g = g_coefficients();
    const double A = -a, B = -b;
    GValue v{0, 0, 0};
    // Horner in B inside, powers of A outside; total degree <= g_degree.
    double Ap = 1.0;
    for (int p = 0; p <= g_degree; ++p) {
        double row = 0, drow = 0;
        for (int q = g_degree - p; q >= 0; --q) {
            drow = drow * B + row;
            row = row * B + g[p][q];
        }
        v.G += Ap * row;
        v.dG_db -= Ap * drow; // dB/db = -1
        if (p + 1 <= g_degree) {
            double row1 = 0;
            for (int q = g_degree - p - 1; q >= 0; --q)
                row1 = row1 * B + g[p + 1][q];
            v.dG_da -= (p + 1) * Ap * row1; // dA/da = -1
        }
        Ap *= A;
    }
    return v;
}

// Where the series form is used: |a|, |b| below this (the series converges
// to round-off well beyond it; above it the direct form loses < 1 digit).
constexpr double series_limit = 1.5;

} // namespace

namespace detail {

CharValue lamb_characteristic(ModeFamily family, double x, double W2, double r, CharForm form)
{
    const double a = r * W2 - x, b = W2 - x;
    const Trig ta = trig(a), tb = trig(b);
    const double bx = W2 - 2 * x; // b - x
    const double P = bx * bx, dP_dx = -4 * bx, dP_dW = 2 * bx;
    CharValue v{};
    const bool series =
        form == CharForm::series || (form == CharForm::automatic && std::max(std::abs(a), std::abs(b)) <= series_limit);
    if (family == ModeFamily::antisymmetric && series) {
        const GValue g = g_series(a, b);
        const double scale = ta.scale * tb.scale;
        const double G = g.G * scale, Ga = g.dG_da * scale, Gb = g.dG_db * scale;
        const double E = (r - 1) * W2; // a - b
        const double T = W2 * W2 * tb.S * ta.C;
        v.F = P * E * G + T;
        v.dF_dx = dP_dx * E * G + P * E * (-Ga - Gb) + W2 * W2 * (-tb.dS * ta.C - tb.S * ta.dC);
        v.dF_dW2 = dP_dW * E * G + P * (r - 1) * G + P * E * (r * Ga + Gb) + 2 * W2 * tb.S * ta.C +
                   W2 * W2 * (tb.dS * ta.C + r * tb.S * ta.dC);
    } else if (family == ModeFamily::antisymmetric) {
        const double Q = 4 * x * b, dQ_dx = 4 * W2 - 8 * x, dQ_dW = 4 * x;
        v.F = P * ta.S * tb.C + Q * tb.S * ta.C;
        v.dF_dx = dP_dx * ta.S * tb.C - P * (ta.dS * tb.C + ta.S * tb.dC) + dQ_dx * tb.S * ta.C -
                  Q * (tb.dS * ta.C + tb.S * ta.dC);
        v.dF_dW2 = dP_dW * ta.S * tb.C + P * (r * ta.dS * tb.C + ta.S * tb.dC) + dQ_dW * tb.S * ta.C +
                   Q * (tb.dS * ta.C + r * tb.S * ta.dC);
    } else {
        const double R = 4 * x * a, dR_dx = 4 * r * W2 - 8 * x, dR_dW = 4 * x * r;
        v.F = P * ta.C * tb.S + R * ta.S * tb.C;
        v.dF_dx = dP_dx * ta.C * tb.S - P * (ta.dC * tb.S + ta.C * tb.dS) + dR_dx * ta.S * tb.C -
                  R * (ta.dS * tb.C + ta.S * tb.dC);
        v.dF_dW2 = dP_dW * ta.C * tb.S + P * (r * ta.dC * tb.S + ta.C * tb.dS) + dR_dW * ta.S * tb.C +
                   R * (r * ta.dS * tb.C + ta.S * tb.dC);
    }
    return v;
}

} // namespace detail

namespace {

void check_inputs(const Material &m, double thickness_m, double f_hz)
{
    if (!(f_hz > 0) || !std::isfinite(f_hz))
        throw std::invalid_argument("frequency must be positive and finite");
    if (!(thickness_m > 0) || !std::isfinite(thickness_m))
        throw std::invalid_argument("thickness must be positive and finite");
    m.validate();
}

// Brent's method on [lo, hi] with f(lo), f(hi) of opposite signs.
template <class Fn>
double brent(Fn &&f, double lo, double hi, double flo, double fhi)
{
    double a = lo, b = hi, fa = flo, fb = fhi, c = a, fc = fa, d = b - a, e = d;
    for (int iter = 0; iter < 200; ++iter) {
        if ((fb > 0) == (fc > 0)) {
            c = a;
            fc = fa;
            d = e = b - a;
        }
        if (std::abs(fc) < std::abs(fb)) {
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        const double tol = 2 * std::numeric_limits<double>::epsilon() * std::abs(b) + 1e-300;
        const double m = 0.5 * (c - b);
        if (std::abs(m) <= tol || fb == 0)
            return b;
        if (std::abs(e) >= tol && std::abs(fa) > std::abs(fb)) {
            double p, q;
            const double s = fb / fa;
            if (a == c) {
                p = 2 * m * s;
                q = 1 - s;
            } else {
                const double qq = fa / fc, rr = fb / fc;
                p = s * (2 * m * qq * (qq - rr) - (b - a) * (rr - 1));
                q = (qq - 1) * (rr - 1) * (s - 1);
            }
            if (p > 0)
                q = -q;
            else
                p = -p;
            if (2 * p < std::min(3 * m * q - std::abs(tol * q), std::abs(e * q))) {
                e = d;
                d = p / q;
            } else {
                d = m;
                e = m;
            }
        } else {
            d = m;
            e = m;
        }
        a = b;
        fa = fb;
        b += std::abs(d) > tol ? d : (m > 0 ? tol : -tol);
        fb = f(b);
    }
    return b;
}

// Kirchhoff wavenumber (k h) from c_L, c_T only (a bound for the A0 search).
double kirchhoff_kh(double W, double r)
{
    // omega^2 = (4/3) k^4 h^2 c_T^2 (1 - r)  =>  (kh)^4 = 3 W^2 / (4 (1 - r))
    return std::pow(3 * W * W / (4 * (1 - r)), 0.25);
}

std::vector<double> scan_grid(double W, double r, double K_hi)
{
    const double W_L = W * std::sqrt(r);
    const int n = 64 + static_cast<int>(std::ceil(16 * W));
    std::vector<double> K;
    K.reserve(3 * n + 300);
    for (int i = 0; i <= n; ++i) {
        const double t = static_cast<double>(i) / n;
        K.push_back(W * t);      // uniform in k
        const double qh = W * t; // uniform in q h
        K.push_back(std::sqrt((W - qh) * (W + qh)));
        const double ph = W_L * t; // uniform in p h
        K.push_back(std::sqrt((W_L - ph) * (W_L + ph)));
    }
    // Evanescent side (c < c_T): at most A0 and S0 live here.
    const int ng = 256;
    const double ratio = std::pow(K_hi / W, 1.0 / ng);
    double k = W;
    for (int i = 1; i <= ng; ++i) {
        k *= ratio;
        K.push_back(k);
    }
    std::sort(K.begin(), K.end());
    K.erase(std::unique(K.begin(), K.end()), K.end());
    return K;
}

ModePoint make_point(ModeFamily family, double f_hz, double h, double ct, double W, double K, double cg)
{
    ModePoint p;
    p.family = family;
    p.f_hz = f_hz;
    p.wavenumber_rad_m = K / h;
    p.phase_velocity_m_s = ct * W / K;
    p.group_velocity_m_s = cg;
    p.wavelength_m = 2 * pi * h / K;
    return p;
}

std::vector<ModePoint> lamb_family(const Material &m, double thickness_m, double f_hz, ModeFamily family)
{
    const double h = 0.5 * thickness_m, ct = m.ct_m_s();
    const double r = m.speed_ratio_squared();
    const double W = 2 * pi * f_hz * h / ct, W2 = W * W;
    auto F = [&](double K) { return detail::lamb_characteristic(family, K * K, W2, r).F; };

    // A0 is slower than both the Kirchhoff and the Rayleigh speed, but not by
    // a factor 4: search k up to 4x the larger of their wavenumbers.
    double K_hi = 4 * std::max(kirchhoff_kh(W, r), W / 0.6);
    std::vector<double> roots;
    for (int attempt = 0; attempt < 4; ++attempt, K_hi *= 4) {
        roots.clear();
        const std::vector<double> K = scan_grid(W, r, K_hi);
        std::vector<double> Fv(K.size());
        for (std::size_t i = 0; i < K.size(); ++i)
            Fv[i] = F(K[i]);
        for (std::size_t i = 0; i + 1 < K.size(); ++i) {
            if (Fv[i] == 0) {
                if (K[i] > 0)
                    roots.push_back(K[i]);
            } else if ((Fv[i] < 0) != (Fv[i + 1] < 0) && Fv[i + 1] != 0) {
                roots.push_back(brent(F, K[i], K[i + 1], Fv[i], Fv[i + 1]));
            }
        }
        // The antisymmetric family always has its A0 root below c_T.
        if (family != ModeFamily::antisymmetric ||
            (!roots.empty() && *std::max_element(roots.begin(), roots.end()) > W))
            break;
    }
    std::sort(roots.begin(), roots.end(), std::greater<>());
    std::vector<ModePoint> out;
    out.reserve(roots.size());
    for (double K : roots) {
        const detail::CharValue v = detail::lamb_characteristic(family, K * K, W2, r);
        const double c = ct * W / K;
        // dW2/dx along F = 0, and c_g = (c_T^2 / c) dW2/dx.
        const double cg = ct * ct / c * (-v.dF_dx / v.dF_dW2);
        ModePoint p = make_point(family, f_hz, h, ct, W, K, cg);
        p.order = static_cast<int>(out.size());
        out.push_back(p);
    }
    return out;
}

std::vector<ModePoint> sh_family(const Material &m, double thickness_m, double f_hz)
{
    // omega^2 = c_T^2 (k^2 + (n pi / d)^2): SH_n, cut-off n c_T / (2d).
    const double h = 0.5 * thickness_m, ct = m.ct_m_s();
    const double W = 2 * pi * f_hz * h / ct; // omega h / c_T
    std::vector<ModePoint> out;
    for (int n = 0;; ++n) {
        const double cut = 0.5 * pi * n; // (n pi / d) h
        if (cut >= W)
            break;
        const double K = std::sqrt((W - cut) * (W + cut));
        const double c = ct * W / K;
        ModePoint p = make_point(ModeFamily::shear_horizontal, f_hz, h, ct, W, K, ct * ct / c);
        p.order = n;
        out.push_back(p);
    }
    return out;
}

} // namespace

std::string ModePoint::name() const
{
    const char *prefix = family == ModeFamily::antisymmetric ? "A" : family == ModeFamily::symmetric ? "S" : "SH";
    return prefix + std::to_string(order);
}

std::vector<ModePoint> solve_family(const Material &m, double thickness_m, double f_hz, ModeFamily family)
{
    check_inputs(m, thickness_m, f_hz);
    if (family == ModeFamily::shear_horizontal)
        return sh_family(m, thickness_m, f_hz);
    return lamb_family(m, thickness_m, f_hz, family);
}

std::vector<ModePoint> solve_modes(const Material &m, double thickness_m, double f_hz)
{
    std::vector<ModePoint> all = solve_family(m, thickness_m, f_hz, ModeFamily::antisymmetric);
    for (ModeFamily fam : {ModeFamily::symmetric, ModeFamily::shear_horizontal}) {
        std::vector<ModePoint> more = solve_family(m, thickness_m, f_hz, fam);
        all.insert(all.end(), more.begin(), more.end());
    }
    return all;
}

ModePoint a0_mode(const Material &m, double thickness_m, double f_hz)
{
    const std::vector<ModePoint> a = solve_family(m, thickness_m, f_hz, ModeFamily::antisymmetric);
    if (a.empty())
        throw std::logic_error("A0 root not found");
    return a.front();
}

ModePoint s0_mode(const Material &m, double thickness_m, double f_hz)
{
    const std::vector<ModePoint> s = solve_family(m, thickness_m, f_hz, ModeFamily::symmetric);
    if (s.empty())
        throw std::logic_error("S0 root not found");
    return s.front();
}

double a0_phase_velocity(const Material &m, double thickness_m, double f_hz)
{
    return a0_mode(m, thickness_m, f_hz).phase_velocity_m_s;
}

double a0_group_velocity(const Material &m, double thickness_m, double f_hz)
{
    return a0_mode(m, thickness_m, f_hz).group_velocity_m_s;
}

double a0_wavelength(const Material &m, double thickness_m, double f_hz)
{
    return a0_mode(m, thickness_m, f_hz).wavelength_m;
}

double kirchhoff_phase_velocity_m_s(double kappa_m2_s, double f_hz) { return std::sqrt(2 * pi * f_hz * kappa_m2_s); }

double kirchhoff_group_velocity_m_s(double kappa_m2_s, double f_hz)
{
    return 2 * kirchhoff_phase_velocity_m_s(kappa_m2_s, f_hz);
}

double kirchhoff_wavelength_m(double kappa_m2_s, double f_hz)
{
    return 2 * pi * std::sqrt(kappa_m2_s / (2 * pi * f_hz));
}

double kirchhoff_phase_velocity(const Material &m, double thickness_m, double f_hz)
{
    check_inputs(m, thickness_m, f_hz);
    return kirchhoff_phase_velocity_m_s(m.kappa(thickness_m), f_hz);
}

double kirchhoff_group_velocity(const Material &m, double thickness_m, double f_hz)
{
    check_inputs(m, thickness_m, f_hz);
    return kirchhoff_group_velocity_m_s(m.kappa(thickness_m), f_hz);
}

double mindlin_shear_factor(const Material &m, MindlinShear choice)
{
    if (choice == MindlinShear::pi2_over_12)
        return pi * pi / 12;
    const double cr = rayleigh_speed(m);
    return (cr / m.ct_m_s()) * (cr / m.ct_m_s());
}

namespace {

// Mindlin plate, plane wave w, psi ~ exp(i(kx - wt)):
//   S D k^4 - (S I + rho d D) w^2 k^2 + rho d w^2 (I w^2 - S) = 0,
// S = k_s^2 G d, I = rho d^3 / 12. Returns k and d(omega)/dk of the flexural
// (larger k^2) root.
struct MindlinRoot {
    double k, cg;
};

MindlinRoot mindlin_root(const Material &m, double d, double f_hz, MindlinShear choice)
{
    check_inputs(m, d, f_hz);
    const double w2 = (2 * pi * f_hz) * (2 * pi * f_hz);
    const double S = mindlin_shear_factor(m, choice) * m.shear_modulus_pa() * d;
    const double D = m.bending_stiffness(d);
    const double I = m.density_kg_m3 * d * d * d / 12, rd = m.density_kg_m3 * d;
    const double beta = (S * I + rd * D) * w2;
    const double disc = w2 * w2 * (S * I - rd * D) * (S * I - rd * D) + 4 * S * S * D * rd * w2;
    const double k2 = (beta + std::sqrt(disc)) / (2 * S * D);
    const double dphi_dk2 = 2 * S * D * k2 - (S * I + rd * D) * w2;
    const double dphi_dw2 = -(S * I + rd * D) * k2 + 2 * rd * I * w2 - rd * S;
    const double k = std::sqrt(k2);
    return {k, k / std::sqrt(w2) * (-dphi_dk2 / dphi_dw2)};
}

} // namespace

double mindlin_phase_velocity(const Material &m, double thickness_m, double f_hz, MindlinShear choice)
{
    return 2 * pi * f_hz / mindlin_root(m, thickness_m, f_hz, choice).k;
}

double mindlin_group_velocity(const Material &m, double thickness_m, double f_hz, MindlinShear choice)
{
    return mindlin_root(m, thickness_m, f_hz, choice).cg;
}

double rayleigh_speed(const Material &m)
{
    // (2 - xi)^2 = 4 sqrt(1 - xi) sqrt(1 - r xi), xi = (c/c_T)^2; the root lies
    // in (0.3, 1) for every nu in (-1, 0.5), the other side of xi = 0 (trivial).
    m.validate();
    const double r = m.speed_ratio_squared();
    auto f = [r](double xi) { return (2 - xi) * (2 - xi) - 4 * std::sqrt(1 - xi) * std::sqrt(1 - r * xi); };
    const double xi = brent(f, 0.3, 1.0, f(0.3), f(1.0));
    return m.ct_m_s() * std::sqrt(xi);
}

double plate_speed(const Material &m)
{
    m.validate();
    return std::sqrt(m.youngs_pa / (m.density_kg_m3 * (1 - m.poisson * m.poisson)));
}

std::vector<double> cutoff_frequencies(const Material &m, double thickness_m, ModeFamily family, double f_max_hz)
{
    const double fT = m.ct_m_s() / (2 * thickness_m), fL = m.cl_m_s() / (2 * thickness_m);
    std::vector<double> out;
    auto add = [&](double base, int first, int step) {
        for (int n = first; n * base <= f_max_hz; n += step)
            out.push_back(n * base);
    };
    switch (family) {
    case ModeFamily::antisymmetric:
        add(fT, 1, 2);
        add(fL, 2, 2);
        break;
    case ModeFamily::symmetric:
        add(fT, 2, 2);
        add(fL, 1, 2);
        break;
    case ModeFamily::shear_horizontal:
        add(fT, 1, 1);
        break;
    }
    std::sort(out.begin(), out.end());
    return out;
}

} // namespace calib::physics
