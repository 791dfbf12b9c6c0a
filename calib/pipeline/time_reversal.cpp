#include "pipeline/time_reversal.h"

#include <soxr.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

std::vector<double> resample(const std::vector<double> &x, double in_rate, double out_rate)
{
    return std::move(resample_all({x}, in_rate, out_rate)[0]);
}

std::vector<std::vector<double>> resample_all(const std::vector<std::vector<double>> &x, double in_rate,
                                              double out_rate)
{
    if (x.empty())
        return {};
    const std::size_t len = x[0].size();
    for (const std::vector<double> &c : x)
        if (c.size() != len)
            throw std::invalid_argument("resample: signals differ in length");
    if (len == 0 || in_rate == out_rate)
        return x;
    const auto out_len = static_cast<size_t>(std::llround(static_cast<double>(len) * out_rate / in_rate));
    std::vector<std::vector<double>> y(x.size(), std::vector<double>(out_len));
    std::vector<const double *> in(x.size());
    std::vector<double *> out(x.size());
    for (std::size_t c = 0; c < x.size(); c++) {
        in[c] = x[c].data();
        out[c] = y[c].data();
    }
    size_t done = 0;
    // One filter design for every channel: soxr runs them one after another
    // through the same filter ("split" channels, one buffer each).
    const soxr_io_spec_t io = soxr_io_spec(SOXR_FLOAT64_S, SOXR_FLOAT64_S);
    const soxr_quality_spec_t q = soxr_quality_spec(SOXR_HQ | SOXR_LINEAR_PHASE, 0);
    const soxr_runtime_spec_t rt = soxr_runtime_spec(1);
    soxr_error_t err = soxr_oneshot(in_rate, out_rate, unsigned(x.size()), in.data(), len, nullptr, out.data(),
                                    out_len, &done, &io, &q, &rt);
    if (err)
        throw std::runtime_error(std::string("soxr: ") + err);
    for (std::vector<double> &c : y)
        c.resize(done);
    return y;
}

DriveSignals make_drive_signals(const std::vector<std::vector<double>> &rec, double sim_rate_hz,
                                double pulse_duration_s, const TimeReversalOptions &o)
{
    if (rec.empty() || rec[0].empty())
        throw std::invalid_argument("no recordings");
    if (!(o.truncate_fraction > 0 && o.truncate_fraction <= 1))
        throw std::invalid_argument("truncate_fraction must be in (0, 1]");
    const size_t n = rec[0].size();
    const auto keep = std::max<size_t>(1, static_cast<size_t>(std::llround(o.truncate_fraction * n)));
    std::vector<std::vector<double>> drive(rec.size());
    for (size_t c = 0; c < rec.size(); c++) {
        if (rec[c].size() != n)
            throw std::invalid_argument("recordings differ in length");
        std::vector<double> &s = drive[c];
        s.resize(keep);
        for (size_t i = 0; i < keep; i++) {
            const double v = rec[c][keep - 1 - i];  // reversed
            if (!std::isfinite(v))
                throw std::invalid_argument("recording of channel " + std::to_string(c) + " is not finite at sample " +
                                            std::to_string(keep - 1 - i));
            s[i] = v;
        }
    }
    // Sample i of the output is recording sample keep-1-i: time reverses about (keep-1)/rate.
    return finish_drive_signals(std::move(drive), sim_rate_hz, static_cast<double>(keep - 1) / sim_rate_hz - pulse_duration_s / 2,
                                o);
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
    if (!std::isfinite(32767.0 / peak))  // a denormal peak: as good as zero
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
    const double to_unit = 1.0 / 18446744073709551616.0;  // 2^-64
    for (size_t i = 0; i < d.normalized.size(); i++) {
        double counts = d.normalized[i] * level * 32767.0;
        if (o.dither)
            counts += static_cast<double>(rng()) * to_unit + static_cast<double>(rng()) * to_unit - 1.0;
        d.samples[i] = static_cast<int16_t>(std::clamp(std::lround(counts), static_cast<long>(INT16_MIN), 32767L));
    }
}

}  // namespace calib::pipeline
