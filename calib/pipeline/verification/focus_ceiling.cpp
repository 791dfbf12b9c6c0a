#include "pipeline/verification/focus_ceiling.h"

#include "pipeline/signal/real_fft.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <vector>

namespace calib::pipeline {

namespace {

// Largest |w(r, t)| over t of w = Re sum_f S(f) J0(k r) e^{i 2 pi f t}, for
// the pulse spectrum and the power spectrum at one radius, on the FFT's time
// grid (its period long against the focus). Bins past `bins_used` are zero.
std::array<double, 2> envelopes(const std::vector<std::complex<double>> &target,
                                const std::vector<std::complex<double>> &power, const std::vector<double> &k,
                                std::size_t bins_used, double r, RealFft &fft)
{
    std::vector<double> j0(bins_used);
    for (std::size_t b = 0; b < bins_used; b++)
        j0[b] = std::cyl_bessel_j(0.0, k[b] * r);
    std::array<double, 2> out{};
    for (int which = 0; which < 2; which++) {
        const std::vector<std::complex<double>> &S = which == 0 ? target : power;
        std::complex<double> *X = fft.spectrum();
        std::fill(X, X + fft.bins(), std::complex<double>{});
        for (std::size_t b = 0; b < bins_used; b++)
            X[b] = S[b] * j0[b];
        fft.inverse();
        double m = 0;
        for (std::size_t n = 0; n < fft.size(); n++)
            m = std::max(m, std::abs(fft.real()[n]));
        out[std::size_t(which)] = m;
    }
    return out;
}

} // namespace

FocusCeiling ideal_focus_ceiling(const PulseSpec &pulse, const std::function<double(double)> &wavenumber_per_m,
                                 double radius_m)
{
    if (!(radius_m > 0))
        throw std::invalid_argument("focus ceiling: the radius must be positive");
    // The pulse's band with margin, sampled 8 times its highest significant
    // frequency; a period of >= 64 pulse lengths keeps the sum's wrap-around
    // far from the focus.
    const double f_max = pulse_max_frequency_hz(pulse, 1e-4);
    const double rate = 8 * f_max;
    std::size_t n = 1;
    while (double(n) / rate < 64 * pulse_duration_s(pulse))
        n *= 2;
    RealFft fft(n);
    const std::vector<double> p = sample_pulse(pulse, rate);
    fft.forward_padded(p.data(), p.size());
    const std::size_t bins = fft.bins();
    const std::vector<std::complex<double>> target(fft.spectrum(), fft.spectrum() + bins);
    // The band that carries the pulse (1e-4 of its spectrum's peak); above it, nothing.
    const auto bins_used = std::min(bins, std::size_t(std::ceil(f_max * double(n) / rate)) + 1);
    std::vector<std::complex<double>> power(bins);
    std::vector<double> k(bins, 0.0);
    for (std::size_t b = 0; b < bins_used; b++) {
        k[b] = b == 0 ? 0.0 : wavenumber_per_m(double(b) * rate / double(n));
        power[b] = std::norm(target[b]);
    }
    // Radii from the criterion's edge over four wavelengths at the pulse
    // centre (the rings decay outwards), 100 per wavelength.
    const double lambda = 2 * std::numbers::pi / wavenumber_per_m(pulse.centre_hz);
    const std::array<double, 2> peak = envelopes(target, power, k, bins_used, 0.0, fft);
    std::array<double, 2> worst{};
    FocusCeiling c;
    for (double r = radius_m; r <= radius_m + 4 * lambda; r += lambda / 100) {
        const std::array<double, 2> e = envelopes(target, power, k, bins_used, r, fft);
        if (e[0] > worst[0]) {
            worst[0] = e[0];
            c.target_ring_radius_m = r;
        }
        worst[1] = std::max(worst[1], e[1]);
    }
    c.target_db = 20 * std::log10(peak[0] / worst[0]);
    c.autocorrelation_db = 20 * std::log10(peak[1] / worst[1]);
    return c;
}

} // namespace calib::pipeline
