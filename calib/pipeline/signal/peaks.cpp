#include "pipeline/signal/peaks.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

namespace calib::pipeline {

namespace {

constexpr int half_width = 8;
constexpr int steps_per_sample = 16;
constexpr int table_size = 2 * half_width * steps_per_sample + 1;

// kernel(d) for d = -8 ... 8 in steps of 1/16: sinc under a Kaiser window
// (beta 6: side lobes about -44 dB, the sinc's own band edge at the rate's half).
const std::array<double, table_size> &kernel()
{
    static const std::array<double, table_size> k = [] {
        std::array<double, table_size> t{};
        const double beta = 6.0, i0b = std::cyl_bessel_i(0.0, beta);
        for (int n = 0; n < table_size; n++) {
            const double d = double(n - half_width * steps_per_sample) / steps_per_sample;
            const double r = d / half_width;
            const double w = std::cyl_bessel_i(0.0, beta * std::sqrt(std::max(0.0, 1 - r * r))) / i0b;
            t[n] = (d == 0 ? 1.0 : std::sin(std::numbers::pi * d) / (std::numbers::pi * d)) * w;
        }
        return t;
    }();
    return k;
}

// x at i0 + m / 16 (0 <= m < 16) from the table.
double at_sixteenth(const float *x, std::size_t n, long i0, int m)
{
    const auto &k = kernel();
    double acc = 0;
    for (long i = i0 - half_width + 1; i <= i0 + half_width; i++) {
        if (i < 0 || i >= long(n))
            continue;
        const long idx = (i0 - i) * steps_per_sample + m + half_width * steps_per_sample;
        if (idx >= 0 && idx < table_size)
            acc += double(x[i]) * k[std::size_t(idx)];
    }
    return acc;
}

} // namespace

double interpolate(const float *x, std::size_t n, double t)
{
    if (n == 0)
        return 0;
    const double f = std::floor(t);
    const double u = (t - f) * steps_per_sample;
    const double m = std::floor(u);
    const double a = at_sixteenth(x, n, long(f), int(m));
    const double b =
        m + 1 < steps_per_sample ? at_sixteenth(x, n, long(f), int(m) + 1) : at_sixteenth(x, n, long(f) + 1, 0);
    return a + (u - m) * (b - a); // linear between 1/16 steps: 1e-4 for content below a quarter of the rate
}

double sample_peak(const float *x, std::size_t n)
{
    double p = 0;
    for (std::size_t i = 0; i < n; i++)
        p = std::max(p, double(std::abs(x[i])));
    return p;
}

Peak refined_peak(const float *x, std::size_t n)
{
    Peak best;
    const double top = sample_peak(x, n);
    if (!(top > 0))
        return best;
    for (std::size_t i = 0; i < n; i++) {
        const double a = std::abs(x[i]);
        if (a < 0.8 * top || (i > 0 && std::abs(x[i - 1]) > a) || (i + 1 < n && std::abs(x[i + 1]) > a))
            continue;
        // Scan i - 1 ... i + 1 in 1/16 steps, then a parabola through the best three.
        double vals[2 * steps_per_sample + 1];
        int bi = 0;
        for (int s = 0; s <= 2 * steps_per_sample; s++) {
            const long base = long(i) - 1 + s / steps_per_sample;
            vals[s] = std::abs(at_sixteenth(x, n, base, s % steps_per_sample));
            if (vals[s] > vals[bi])
                bi = s;
        }
        double v = vals[bi], off = 0;
        if (bi > 0 && bi < 2 * steps_per_sample) {
            const double l = vals[bi - 1], c = vals[bi], r = vals[bi + 1];
            const double den = l - 2 * c + r;
            if (den < 0) {
                off = 0.5 * (l - r) / den;
                v = c - 0.25 * (l - r) * off;
            }
        }
        if (v > best.value) {
            best.value = v;
            best.index = double(i) - 1 + (bi + off) / steps_per_sample;
        }
    }
    return best;
}

} // namespace calib::pipeline
