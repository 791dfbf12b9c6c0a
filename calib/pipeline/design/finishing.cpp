#include "pipeline/design/finishing.h"

#include "pipeline/signal/resample.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

TimeReversalOptions drive_options(const CalibrationInput &in, uint64_t drive)
{
    TimeReversalOptions o;
    o.truncate_fraction = in.calibration.truncate_fraction;
    o.output_rate_hz = in.calibration.output_rate_hz;
    o.dither = in.calibration.dither;
    o.dither_seed = dither_seed(in, drive);
    return o;
}

DriveSignals finish_drive_signals(std::vector<std::vector<double>> drive, double sim_rate_hz, double focus_delay_s,
                                  const TimeReversalOptions &o)
{
    if (drive.empty() || drive[0].empty())
        throw std::invalid_argument("no drive samples");
    const size_t keep = drive[0].size();
    const size_t fade = std::min(keep / 4, static_cast<size_t>(std::llround(o.taper_s * sim_rate_hz)));
    DriveSignals d;
    d.channels = static_cast<unsigned>(drive.size());
    d.rate_hz = o.output_rate_hz;
    d.focus_delay_s = focus_delay_s;
    std::vector<std::vector<double>> out(drive.size());
    double peak = 0;
    for (size_t c = 0; c < drive.size(); c++) {
        std::vector<double> &s = drive[c];
        if (s.size() != keep)
            throw std::invalid_argument("drive channels differ in length");
        for (double v : s)
            if (!std::isfinite(v))
                throw std::invalid_argument("drive of channel " + std::to_string(c) + " is not finite");
        // Raised-cosine fades: the reversed signal starts where the kept window
        // was cut mid-wave; without a fade that step is an audible click.
        for (size_t i = 0; i < fade; i++) {
            const double w = 0.5 * (1 - std::cos(std::numbers::pi * (static_cast<double>(i) + 0.5) / fade));
            s[i] *= w;
            s[keep - 1 - i] *= w;
        }
        out[c] = resample(s, sim_rate_hz, o.output_rate_hz);
        for (double v : out[c])
            peak = std::max(peak, std::abs(v));
    }
    if (!(peak > 0) || !std::isfinite(peak))
        throw std::invalid_argument("all recordings are zero: no exciter site receives the pulse from this focus");
    if (!std::isfinite(32767.0 / peak)) // a denormal peak: as good as zero
        throw std::invalid_argument("the recordings' peak (" + std::to_string(peak) +
                                    ") is too small to normalize: no exciter site receives the pulse");

    d.frames = out[0].size();
    d.gain = 32767.0 / peak;
    d.normalized.resize(d.frames * d.channels);
    for (size_t f = 0; f < d.frames; f++)
        for (unsigned c = 0; c < d.channels; c++)
            d.normalized[f * d.channels + c] = out[c][f] / peak;
    requantize(d, 1.0, o);
    return d;
}

void requantize(DriveSignals &d, double level, const TimeReversalOptions &o)
{
    if (!(level > 0 && level <= 1))
        throw std::invalid_argument("playback level must lie in (0, 1]");
    d.level = level;
    d.samples.resize(d.normalized.size());
    // TPDF dither from a seeded generator: soxr's own dither is seeded from the
    // clock, which would make two calibrations of one scene differ.
    std::mt19937_64 rng(o.dither_seed);
    const double to_unit = 1.0 / 18446744073709551616.0; // 2^-64
    for (size_t i = 0; i < d.normalized.size(); i++) {
        double counts = d.normalized[i] * level * 32767.0;
        if (o.dither)
            counts += static_cast<double>(rng()) * to_unit + static_cast<double>(rng()) * to_unit - 1.0;
        d.samples[i] = static_cast<int16_t>(std::clamp(std::lround(counts), static_cast<long>(INT16_MIN), 32767L));
    }
}

// Pre-compensates every channel by the regularised inverse of the exciter
// (engine/effects/exciter.h), renormalises to peak 1 and requantises; the
// gain follows, so `counts / gain` is still the force the plate receives.
void precompensate_for_exciter(DriveSignals &d, const engine::effects::ExciterSpec &e, const TimeReversalOptions &tro)
{
    const size_t C = d.channels, N = d.frames;
    std::vector<double> ch(N);
    double peak = 0;
    for (size_t c = 0; c < C; c++) {
        for (size_t n = 0; n < N; n++)
            ch[n] = d.normalized[n * C + c];
        const std::vector<double> y = engine::effects::precompensate(ch, d.rate_hz, e);
        for (size_t n = 0; n < N; n++) {
            d.normalized[n * C + c] = y[n];
            peak = std::max(peak, std::abs(y[n]));
        }
    }
    if (!(peak > 0))
        return;
    for (double &v : d.normalized)
        v /= peak;
    d.gain /= peak;
    requantize(d, d.level, tro);
}

} // namespace calib::pipeline
