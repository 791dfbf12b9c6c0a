#include "pipeline/signal/deconvolve.h"

#include "pipeline/signal/real_fft.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

constexpr double regularisation = 1e-6; // eps / the band's largest |X|^2

} // namespace

double deconvolution_taper(double f, double f_lo, double f_hi)
{
    if (!(f > f_lo && f < f_hi))
        return 0;
    const double octaves = std::min(1.0 / 3, std::log2(f_hi / f_lo) / 4);
    const double up = std::log2(f / f_lo) / octaves, down = std::log2(f_hi / f) / octaves;
    double w = 1;
    if (up < 1)
        w *= 0.5 * (1 - std::cos(std::numbers::pi * up));
    if (down < 1)
        w *= 0.5 * (1 - std::cos(std::numbers::pi * down));
    return w;
}

std::size_t deconvolution_fft_size(std::size_t samples)
{
    std::size_t best = 1;
    while (best < samples)
        best *= 2;
    for (std::size_t p5 = 1; p5 < best; p5 *= 5)
        for (std::size_t p35 = p5; p35 < best; p35 *= 3) {
            std::size_t v = p35;
            while (v < samples)
                v *= 2;
            best = std::min(best, v);
        }
    return std::max<std::size_t>(best, 2);
}

std::vector<double> impulse_response(const double *recording, std::size_t n, const double *excitation, std::size_t m,
                                     std::size_t ir_length, double f_lo, double f_hi, double rate)
{
    if (n == 0 || m == 0 || ir_length == 0)
        throw std::invalid_argument("deconvolution: empty recording, excitation or response");
    if (ir_length > n)
        throw std::invalid_argument("deconvolution: a response of " + std::to_string(ir_length) +
                                    " samples from a recording of " + std::to_string(n));
    if (!(rate > 0 && f_lo > 0 && f_lo < f_hi && f_hi <= rate / 2))
        throw std::invalid_argument("deconvolution: the band must satisfy 0 < f_lo < f_hi <= rate / 2");
    const std::size_t N = deconvolution_fft_size(n + m);
    RealFft fft(N);
    fft.forward_padded(excitation, m);
    const std::vector<std::complex<double>> X(fft.spectrum(), fft.spectrum() + fft.bins());
    double peak = 0;
    for (std::size_t k = 0; k < X.size(); k++) {
        const double f = double(k) * rate / double(N);
        if (f >= f_lo && f <= f_hi)
            peak = std::max(peak, std::norm(X[k]));
    }
    if (!(peak > 0))
        throw std::invalid_argument("deconvolution: the excitation has no energy in the band");
    const double eps = regularisation * peak;
    fft.forward_padded(recording, n);
    std::complex<double> *R = fft.spectrum();
    for (std::size_t k = 0; k < X.size(); k++) {
        const double w = deconvolution_taper(double(k) * rate / double(N), f_lo, f_hi);
        R[k] = w == 0 ? 0.0 : R[k] * std::conj(X[k]) * (w / (std::norm(X[k]) + eps));
    }
    fft.inverse();
    std::vector<double> h(fft.real(), fft.real() + ir_length);
    for (double &v : h)
        v /= double(N);
    return h;
}

} // namespace calib::pipeline
