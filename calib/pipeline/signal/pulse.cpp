#include "pipeline/signal/pulse.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <optional>
#include <stdexcept>

namespace calib::pipeline {

using std::numbers::pi;

PulseShape parse_pulse_shape(const std::string &name)
{
    if (name == "hann_burst")
        return PulseShape::hann_burst;
    if (name == "gaussian_burst")
        return PulseShape::gaussian_burst;
    if (name == "ricker")
        return PulseShape::ricker;
    throw std::invalid_argument("unknown pulse shape '" + name + "' (known: hann_burst, gaussian_burst, ricker)");
}

double pulse_duration_s(const PulseSpec &p)
{
    // Ricker (1 - 2u^2) exp(-u^2), u = pi f (t - T/2): below 1.2e-4 of its peak for |u| >= 3.5.
    if (p.shape == PulseShape::ricker)
        return 2.0 * 3.5 / (pi * p.centre_hz);
    return p.cycles / p.centre_hz;
}

double pulse_value(const PulseSpec &p, double t)
{
    const double T = pulse_duration_s(p);
    if (t < 0.0 || t >= T)
        return 0.0;
    const double f = p.centre_hz;
    switch (p.shape) {
    case PulseShape::hann_burst:
        return std::sin(2 * pi * f * t) * 0.5 * (1.0 - std::cos(2 * pi * t / T));
    case PulseShape::gaussian_burst: {
        // exp(-a u^2) = 0.01 (-40 dB) at the ends u = +-T/2.
        const double u = t - T / 2, a = std::log(100.0) / (T * T / 4);
        return std::sin(2 * pi * f * u) * std::exp(-a * u * u);
    }
    case PulseShape::ricker: {
        const double u = pi * f * (t - T / 2);
        return (1.0 - 2.0 * u * u) * std::exp(-u * u);
    }
    }
    return 0.0;
}

std::vector<double> sample_pulse(const PulseSpec &p, double rate_hz)
{
    const auto n = static_cast<size_t>(std::ceil(pulse_duration_s(p) * rate_hz));
    std::vector<double> v(n);
    for (size_t i = 0; i < n; i++)
        v[i] = pulse_value(p, static_cast<double>(i) / rate_hz);
    return v;
}

namespace {

// The highest frequency where the pulse's amplitude spectrum reaches `level` of its peak.
double spectrum_edge_hz(const PulseSpec &p, double level)
{
    const double rate = 64.0 * p.centre_hz;
    const std::vector<double> x = sample_pulse(p, rate);
    const int bins = 2000;
    const double fmax_scan = 8.0 * p.centre_hz;
    std::vector<double> mag(bins + 1);
    double peak = 0;
    for (int b = 0; b <= bins; b++) {
        const double f = fmax_scan * b / bins;
        std::complex<double> acc = 0;
        for (size_t i = 0; i < x.size(); i++)
            acc += x[i] * std::polar(1.0, -2 * pi * f * static_cast<double>(i) / rate);
        mag[b] = std::abs(acc);
        peak = std::max(peak, mag[b]);
    }
    for (int b = bins; b >= 0; b--)
        if (mag[b] >= level * peak)
            return fmax_scan * b / bins;
    return 0.0;
}

} // namespace

double pulse_max_frequency_hz(const PulseSpec &p, double level)
{
    // Direct DFT of the finely sampled pulse on a frequency grid up to 8x the
    // centre: a quarter of a million complex exponentials, a few ms. Stages
    // ask it per focus (the inverse filter's band edge, every drive's energy
    // above the band), so each thread keeps its last answer (the amplitude
    // does not enter: the spectrum is taken relative to its peak).
    struct Last {
        PulseShape shape;
        double centre_hz, cycles, level, f_hz;
    };
    static thread_local std::optional<Last> last;
    if (last && last->shape == p.shape && last->centre_hz == p.centre_hz && last->cycles == p.cycles &&
        last->level == level)
        return last->f_hz;
    const double f_hz = spectrum_edge_hz(p, level);
    last = Last{p.shape, p.centre_hz, p.cycles, level, f_hz};
    return f_hz;
}

double search_rate(const PulseSpec &p) { return std::max(2000.0, std::ceil(4.0 * pulse_max_frequency_hz(p))); }

} // namespace calib::pipeline
