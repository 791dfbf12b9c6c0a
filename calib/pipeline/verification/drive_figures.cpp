#include "pipeline/verification/drive_figures.h"

#include "pipeline/data/input.h"
#include "pipeline/signal/pulse.h"

#include <unsupported/Eigen/FFT>

#include <cmath>
#include <complex>

namespace calib::pipeline {

double drive_energy_n2s(const std::vector<int16_t> &samples, double force_full_scale_n, double rate_hz)
{
    const double to_n = force_full_scale_n / 32767.0;
    double e = 0;
    for (const int16_t s : samples)
        e += (s * to_n) * (s * to_n);
    return e / rate_hz;
}

DriveFigures drive_figures(const CalibrationInput &in, const std::vector<int16_t> &samples, unsigned channels,
                           double rate_hz, double peak_m)
{
    DriveFigures d;
    if (channels == 0 || samples.empty())
        return d;
    const std::size_t n = samples.size() / channels;
    const double edge = pulse_max_frequency_hz(in.pulse);
    const double to_n = in.exciters.force_full_scale_n / 32767.0;
    Eigen::FFT<double> fft;
    std::vector<double> x(n);
    std::vector<std::complex<double>> X;
    double total = 0, above = 0;
    for (unsigned c = 0; c < channels; c++) {
        for (std::size_t i = 0; i < n; i++)
            x[i] = samples[i * channels + c] * to_n;
        fft.fwd(X, x);
        // Parseval: sum |x|^2 = (1/n) sum |X|^2; the bins above the edge, both signs.
        for (std::size_t b = 0; b < n; b++) {
            const double f = double(b <= n / 2 ? b : n - b) * rate_hz / double(n);
            const double e = std::norm(X[b]) / double(n);
            total += e;
            if (f > edge)
                above += e;
        }
    }
    d.energy_n2s = total / rate_hz;
    d.out_of_band_fraction = total > 0 ? above / total : 0.0;
    d.peak_per_root_energy = d.energy_n2s > 0 ? peak_m / std::sqrt(d.energy_n2s) : 0.0;
    return d;
}

} // namespace calib::pipeline
