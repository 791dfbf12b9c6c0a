#include "pipeline/design/time_reversal.h"

#include "pipeline/data/lead_time.h"
#include "pipeline/design/exciter_gains.h"
#include "pipeline/signal/first_failure.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/transfer/playback.h"

#include <algorithm>
#include <cmath>
#include <memory>
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

namespace {

// The points the gains are judged on: the foci, then the lattice points in
// the active area (the verdict's), as indices into H.points.
struct GainJudge {
    std::vector<std::size_t> served;
    std::size_t drive_samples = 0;
    std::unique_ptr<Playback> playback;
};

GainJudge gain_judge(const CalibrationInput &in, const TransferMatrix &H, std::size_t keep)
{
    GainJudge j;
    for (std::size_t f = 0; f < in.foci.points.size(); f++)
        j.served.push_back(H.exact_begin() + f);
    for (std::size_t n = 0; n < H.lattice.size(); n++)
        if (in.active.area.contains(H.lattice.at(n)))
            j.served.push_back(n);
    // As the verification plays a drive: its length and the tail after it.
    const auto tail = static_cast<std::size_t>(std::ceil(in.calibration.verify_tail_s * H.rate_hz));
    // The finished drive, at the device rate and back at H's, may run a few
    // samples longer (a sample of either rate, and the resampler's rounding).
    j.drive_samples = keep + 16 + static_cast<std::size_t>(std::ceil(2 * H.rate_hz / in.calibration.output_rate_hz));
    j.playback = std::make_unique<Playback>(H, j.served, j.drive_samples, keep + tail);
    return j;
}

// Focus f's gains (exciter_gains.h) for the recordings rec[c] (kept part
// first): each exciter's reversed recording played alone, its field at the
// focus and, beyond lambda/2 from it, at the other foci and the active
// lattice (the verdict's two criteria). `equal`: the drive with equal gains
// as finished (its channels' peaks at the device rate).
ExciterGains focus_gains(const CalibrationInput &in, const TransferMatrix &H, const GainJudge &judge, std::size_t f,
                         const std::vector<std::vector<double>> &rec, std::size_t keep, const DriveSignals &equal)
{
    const std::size_t C = H.channels;
    std::vector<std::vector<double>> force(C, std::vector<double>(keep));
    for (std::size_t c = 0; c < C; c++)
        for (std::size_t i = 0; i < keep; i++)
            force[c][i] = rec[c][keep - 1 - i];
    const double lambda_half = judged_lambda_half_m(in);
    std::vector<std::size_t> which{f}; // into judge.served
    for (std::size_t s = 0; s < judge.served.size(); s++)
        if (s != f && dist(H.points[judge.served[s]], in.foci.points[f].at) > lambda_half)
            which.push_back(s);
    const std::vector<std::vector<std::vector<float>>> g = judge.playback->channel_fields(force, which);
    const std::size_t T = judge.playback->output_samples();
    // The focal instant: the equal design's peak at the focus.
    std::size_t focal = 0;
    double peak = -1;
    for (std::size_t t = 0; t < T; t++) {
        double v = 0;
        for (std::size_t c = 0; c < C; c++)
            v += g[c][0][t];
        if (std::abs(v) > peak) {
            peak = std::abs(v);
            focal = t;
        }
    }
    Eigen::VectorXd a(static_cast<Eigen::Index>(C));
    for (std::size_t c = 0; c < C; c++)
        a[Eigen::Index(c)] = g[c][0][focal];
    Eigen::MatrixXf G(static_cast<Eigen::Index>(C), static_cast<Eigen::Index>((which.size() - 1) * T));
    for (std::size_t r = 1; r < which.size(); r++)
        for (std::size_t t = 0; t < T; t++)
            for (std::size_t c = 0; c < C; c++)
                G(Eigen::Index(c), Eigen::Index((r - 1) * T + t)) = g[c][r][t];
    ExciterGains gains = minimax_gains(G, a);
    // The exciters' force: the drive is normalised to full scale on its
    // largest channel, so uneven gains lower the focal peak at full scale.
    // Each channel's finishing (fades, the device rate) is linear, so the
    // equal drive as finished, played back at full scale one exciter at a
    // time as every stored drive is played (drive_forces), gives the focal
    // peak of any gains: the sum of the parts at the
    // focus over the largest channel's peak. The gains move from equal
    // towards the minimax ones only as far as the scene's amplitude can
    // still be reached (1 % kept for the dither; where equal gains cannot
    // reach it, as far as the focus stays as high); the largest residual of
    // the blend is at most the blend of the two (convexity), so it never
    // does worse than equal gains.
    std::vector<double> channel_peak(C, 0.0);
    const std::vector<float> frames(equal.normalized.begin(), equal.normalized.end());
    for (std::size_t n = 0; n < equal.frames; n++)
        for (std::size_t c = 0; c < C; c++)
            channel_peak[c] = std::max(channel_peak[c], std::abs(equal.normalized[n * C + c]));
    std::vector<std::vector<double>> full = drive_forces(in, H, frames, unsigned(C), equal.rate_hz);
    for (std::vector<double> &f_c : full)
        if (f_c.size() > judge.drive_samples)
            f_c.resize(judge.drive_samples);
    const std::vector<std::vector<std::vector<float>>> at_focus = judge.playback->channel_fields(full, {f});
    // The focal peak at full scale of the blend s (0: equal gains).
    auto full_scale_peak = [&](double s) {
        double drive = 0, peak = 0;
        for (std::size_t c = 0; c < C; c++)
            drive = std::max(drive, std::abs(1 + s * (gains.gain[c] - 1)) * channel_peak[c]);
        for (std::size_t t = 0; t < at_focus[0][0].size(); t++) {
            double v = 0;
            for (std::size_t c = 0; c < C; c++)
                v += (1 + s * (gains.gain[c] - 1)) * at_focus[c][0][t];
            peak = std::max(peak, std::abs(v));
        }
        return drive > 0 ? peak / drive : 0.0;
    };
    // Where equal gains fall short of the amplitude themselves, the gains
    // may not fall shorter.
    const double target = std::min(1.01 * in.pulse.amplitude_m, full_scale_peak(0));
    auto reaches = [&](double s) { return full_scale_peak(s) >= target; };
    if (!reaches(1)) {
        double lo = 0, hi = 1; // reaches(lo) or lo = 0: the equal gains, as far as they go
        for (int it = 0; it < 20; it++) {
            const double mid = (lo + hi) / 2;
            (reaches(mid) ? lo : hi) = mid;
        }
        for (double &w : gains.gain)
            w = 1 + lo * (w - 1);
    }
    return gains;
}

} // namespace

std::vector<DriveSignals> signals_from_transfer(const CalibrationInput &in, const TransferMatrix &H,
                                                const ProgressFn &progress, const TransferMatrix *judged_on)
{
    const TransferMatrix &J = judged_on ? *judged_on : H;
    if (J.channels != H.channels || J.rate_hz != H.rate_hz ||
        J.point_count() - J.exact_begin() != H.point_count() - H.exact_begin())
        throw std::logic_error(
            "time reversal: the gains' transfer matrix differs from the design's in its exciters, rate or foci");
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
    const bool judged = in.calibration.exciter_gains == ExciterGainsMode::minimax && J.lattice.size() > 0;
    const GainJudge judge = judged ? gain_judge(in, J, keep) : GainJudge{};
    FirstFailure failure;
    std::size_t done = 0;
    if (judged && progress)
        progress("signals", 0, out.size());
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
            if (judged) {
                const ExciterGains gains = focus_gains(in, J, judge, f, rec, keep, out[f]);
                for (std::size_t c = 0; c < H.channels; c++)
                    for (double &v : rec[c])
                        v *= gains.gain[c];
                out[f] = make_drive_signals(rec, H.rate_hz, pulse_duration_s(in.pulse), o);
            }
        } catch (const std::exception &e) {
            failure.keep(f, "focus " + std::to_string(in.foci.points[f].id) + ": " + e.what());
        }
        if (judged && progress) {
#pragma omp critical(time_reversal_progress)
            progress("signals", ++done, out.size());
        }
    }
    failure.rethrow();
    return out;
}

} // namespace calib::pipeline
