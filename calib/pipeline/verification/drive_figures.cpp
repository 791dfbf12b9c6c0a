#include "pipeline/verification/drive_figures.h"

#include "pipeline/data/input.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/signal/real_fft.h"

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
    if (n < 2) { // one frame: all of it at DC
        d.energy_n2s = drive_energy_n2s(samples, in.exciters.force_full_scale_n, rate_hz);
        d.peak_per_root_energy = d.energy_n2s > 0 ? peak_m / std::sqrt(d.energy_n2s) : 0.0;
        return d;
    }
    // FFTW at the drive's own length (any length in O(n log n): Eigen's
    // kissfft took O(n p) for a prime factor p, seconds for a prime-length drive).
    RealFft fft(n);
    double total = 0, above = 0;
    for (unsigned c = 0; c < channels; c++) {
        double *x = fft.real();
        for (std::size_t i = 0; i < n; i++)
            x[i] = samples[i * channels + c] * to_n;
        fft.forward();
        const std::complex<double> *X = fft.spectrum();
        // Parseval: sum |x|^2 = (1/n) sum over all n bins of |X|^2; bin b and
        // bin n - b are conjugates, so each bin of the half spectrum but DC
        // (and, n even, the Nyquist bin) stands for two.
        for (std::size_t b = 0; b <= n / 2; b++) {
            const double f = double(b) * rate_hz / double(n);
            const double twice = (b == 0 || 2 * b == n) ? 1.0 : 2.0;
            const double e = twice * std::norm(X[b]) / double(n);
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
