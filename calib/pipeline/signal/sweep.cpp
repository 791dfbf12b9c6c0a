#include "pipeline/signal/sweep.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

using std::numbers::pi;

void check_sweep(const SweepSpec &s)
{
    if (!(s.rate_hz > 0 && std::isfinite(s.rate_hz)))
        throw std::invalid_argument("sweep: the rate must be > 0");
    if (!(s.f1_hz > 0 && s.f1_hz < s.f2_hz && s.f2_hz < s.rate_hz / 2))
        throw std::invalid_argument("sweep: the band must satisfy 0 < f1 < f2 < rate / 2, got " +
                                    std::to_string(s.f1_hz) + " to " + std::to_string(s.f2_hz) + " Hz at " +
                                    std::to_string(s.rate_hz) + " Hz");
    if (!(s.duration_s > 0 && std::isfinite(s.duration_s) && s.duration_s * s.rate_hz >= 2))
        throw std::invalid_argument("sweep: the duration must be at least two samples");
    if (!(s.amplitude > 0 && s.amplitude <= 1))
        throw std::invalid_argument("sweep: the amplitude must lie in (0, 1] of full scale");
    if (!(s.fade_in_octaves >= 0 && s.fade_out_octaves >= 0 &&
          s.fade_in_octaves + s.fade_out_octaves <= std::log2(s.f2_hz / s.f1_hz)))
        throw std::invalid_argument("sweep: the fades are longer than the sweep");
}

double sweep_rate_constant_s(const SweepSpec &s) { return s.duration_s / std::log(s.f2_hz / s.f1_hz); }

double sweep_phase(const SweepSpec &s, double t_s)
{
    const double L = sweep_rate_constant_s(s);
    return 2 * pi * s.f1_hz * L * std::expm1(t_s / L);
}

double sweep_frequency_hz(const SweepSpec &s, double t_s) { return s.f1_hz * std::exp(t_s / sweep_rate_constant_s(s)); }

std::size_t sweep_frames(const SweepSpec &s)
{
    return static_cast<std::size_t>(std::llround(s.duration_s * s.rate_hz));
}

std::vector<double> exponential_sweep(const SweepSpec &s)
{
    check_sweep(s);
    const double L = sweep_rate_constant_s(s), T = s.duration_s;
    const double fade_in = L * s.fade_in_octaves * std::numbers::ln2;
    const double fade_out = L * s.fade_out_octaves * std::numbers::ln2;
    const std::size_t n = sweep_frames(s);
    std::vector<double> x(n);
    for (std::size_t i = 0; i < n; i++) {
        const double t = double(i) / s.rate_hz;
        double w = 1;
        if (t < fade_in)
            w = 0.5 * (1 - std::cos(pi * t / fade_in));
        if (T - t < fade_out)
            w *= 0.5 * (1 - std::cos(pi * std::max(T - t, 0.0) / fade_out));
        x[i] = s.amplitude * w * std::sin(sweep_phase(s, t));
    }
    return x;
}

double harmonic_lead_s(const SweepSpec &s, int k) { return sweep_rate_constant_s(s) * std::log(double(k)); }

double deconvolved_snr_db(double recording_snr_db, double sweep_s, double bandwidth_hz)
{
    return recording_snr_db + 10 * std::log10(sweep_s * bandwidth_hz);
}

double sweep_s_for_snr(double deconvolved_snr_db, double recording_snr_db, double bandwidth_hz)
{
    return std::pow(10.0, (deconvolved_snr_db - recording_snr_db) / 10) / bandwidth_hz;
}

PlanLayout plan_layout(std::size_t channels, std::size_t lead_frames, std::size_t sweep_frames, std::size_t gap_frames)
{
    PlanLayout p;
    p.channels = channels;
    p.lead_frames = lead_frames;
    p.sweep_frames = sweep_frames;
    p.gap_frames = gap_frames;
    for (std::size_t c = 0; c < channels; c++)
        p.start_frames.push_back(lead_frames + c * (sweep_frames + gap_frames));
    p.total_frames = lead_frames + channels * (sweep_frames + gap_frames);
    return p;
}

std::vector<int16_t> quantize_pcm16(const std::vector<double> &x)
{
    std::vector<int16_t> q(x.size());
    for (std::size_t i = 0; i < x.size(); i++)
        q[i] = static_cast<int16_t>(std::clamp(std::lround(x[i] * 32768.0), -32768L, 32767L));
    return q;
}

std::vector<int16_t> plan_samples(const PlanLayout &layout, const std::vector<int16_t> &sweep)
{
    if (sweep.size() != layout.sweep_frames)
        throw std::invalid_argument("plan: the sweep has " + std::to_string(sweep.size()) + " samples, the layout " +
                                    std::to_string(layout.sweep_frames));
    std::vector<int16_t> out(layout.total_frames * layout.channels, 0);
    for (std::size_t c = 0; c < layout.channels; c++)
        for (std::size_t i = 0; i < sweep.size(); i++)
            out[(layout.start_frames[c] + i) * layout.channels + c] = sweep[i];
    return out;
}

} // namespace calib::pipeline
