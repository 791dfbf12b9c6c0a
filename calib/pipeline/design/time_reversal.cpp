#include "pipeline/design/time_reversal.h"

#include "pipeline/data/lead_time.h"
#include "pipeline/signal/first_failure.h"
#include "pipeline/signal/pulse.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

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
            const double v = rec[c][keep - 1 - i]; // reversed
            if (!std::isfinite(v))
                throw std::invalid_argument("recording of channel " + std::to_string(c) + " is not finite at sample " +
                                            std::to_string(keep - 1 - i));
            s[i] = v;
        }
    }
    // Sample i of the output is recording sample keep-1-i: time reverses about (keep-1)/rate.
    return finish_drive_signals(std::move(drive), sim_rate_hz,
                                static_cast<double>(keep - 1) / sim_rate_hz - pulse_duration_s / 2, o);
}

std::vector<DriveSignals> signals_from_transfer(const CalibrationInput &in, const TransferMatrix &H)
{
    const std::vector<double> pulse = sample_pulse(in.pulse, H.rate_hz);
    // The recording window at H's rate; only its kept part is non-zero in use,
    // and H covers it (transfer_options: the kept window and the tail).
    const auto n = static_cast<size_t>(std::llround(in.calibration.window_s * H.rate_hz));
    const auto keep = static_cast<size_t>(std::llround(kept_fraction(in) * double(n)));
    if (keep > H.samples)
        throw std::logic_error("transfer matrix shorter than the kept window");
    // The kept window the lead time asks for (data/lead_time.h).
    const double kept = in.calibration.lead_time_s ? double(keep) / double(n) : in.calibration.truncate_fraction;
    // One focus per thread; each focus's dither seed is its own (dither_seed),
    // so the signals do not depend on the thread count.
    std::vector<DriveSignals> out(in.foci.points.size());
    FirstFailure failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t f = 0; f < in.foci.points.size(); f++) {
        std::vector<std::vector<double>> rec(H.channels, std::vector<double>(n, 0.0));
        for (size_t c = 0; c < H.channels; c++) {
            const float *h = H.response(c, H.exact_begin() + f);
            for (size_t t = 0; t < keep; t++) { // r = p * h, causal
                double acc = 0;
                for (size_t m = 0; m < pulse.size() && m <= t; m++)
                    acc += pulse[m] * double(h[t - m]);
                rec[c][t] = acc;
            }
        }
        TimeReversalOptions o = drive_options(in, f);
        o.truncate_fraction = kept;
        try {
            out[f] = make_drive_signals(rec, H.rate_hz, pulse_duration_s(in.pulse), o);
        } catch (const std::exception &e) {
            failure.keep(f, "focus " + std::to_string(in.foci.points[f].id) + ": " + e.what());
        }
    }
    failure.rethrow();
    return out;
}

} // namespace calib::pipeline
