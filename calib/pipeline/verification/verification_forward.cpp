// The forward verification path: one simulation per focus with the drive
// applied at the exciters, for scenes whose plate changes with the touch
// ([effects.finger]: the finger presses at the focus while its signals play),
// where the transfer matrix does not hold. It measures the foci at every step
// and the field at each focus instant on the plate grid (a second run to that
// step), not the whole area at all times.
#include "pipeline/verification/verification.h"

#include "engine/effects/exciter.h"
#include "pipeline/signal/resample.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

// Forces (N) at the simulation's rate from drive samples at rate_hz (full scale 1.0).
std::vector<double> drive_force(const std::vector<float> &x_full_scale, double rate_hz, double sim_rate_hz,
                                double force_full_scale_n)
{
    std::vector<double> x(x_full_scale.begin(), x_full_scale.end());
    std::vector<double> y = resample(x, rate_hz, sim_rate_hz);
    for (double &v : y)
        v *= force_full_scale_n;
    return y;
}

void require_finite(const std::vector<double> &trace, const char *what, size_t index)
{
    for (size_t n = 0; n < trace.size(); n++)
        if (!std::isfinite(trace[n]))
            throw std::runtime_error(std::string(what) + " " + std::to_string(index) +
                                     ": non-finite displacement at step " + std::to_string(n) +
                                     " (the simulation diverged)");
}

} // namespace

namespace {

// Drives the exciters with forces from `frames` ([n][c], full scale 1.0) for
// `steps` steps, recording every focus.
engine::Simulation drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                         const std::vector<float> &frames, unsigned channels, double rate_hz, size_t steps)
{
    engine::Simulation sim(in.plate, single_core_options(in));
    const double k = sim.time_step_s();
    const size_t n = frames.size() / channels;
    for (unsigned c = 0; c < channels; c++) {
        std::vector<float> ch(n);
        for (size_t i = 0; i < n; i++)
            ch[i] = frames[i * channels + c];
        const size_t src = sim.add_source(exciters[c].x_m, exciters[c].y_m);
        std::vector<double> force =
            drive_force(ch, rate_hz, 1.0 / k, in.exciters.force_full_scale_n * in.exciters.force_gain(c));
        if (in.effects.exciter) // the drive is Bl i; the plate gets the exciter's blocked force
            force = engine::effects::blocked_force(force, 1.0 / k, *in.effects.exciter);
        sim.set_source_signal(src, std::move(force));
    }
    for (const FocusPoint &f : in.foci.points)
        sim.add_receiver(f.at.x_m, f.at.y_m);
    if (in.effects.finger) // playback: the finger presses while the signals play, not during calibration
        sim.add_finger(*in.effects.finger);
    sim.run(steps);
    return sim;
}

} // namespace

Verification verify_signals_forward(const CalibrationInput &in, const std::vector<Point> &exciters,
                                    const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                    const ProgressFn &progress, bool snapshots)
{
    const size_t K = in.foci.points.size();
    if (signals.size() != K)
        throw std::invalid_argument("verification: " + std::to_string(signals.size()) + " signals for " +
                                    std::to_string(K) + " foci");
    const auto channels = static_cast<unsigned>(exciters.size());
    Verification v;
    v.foci.resize(K);
    v.traces.resize(K);
    v.snapshots.resize(K);
    const engine::Grid &g = in.plate->grid();
    v.grid_nx = g.nx;
    v.grid_ny = g.ny;
    v.grid_h_m = g.h;
    const double lambda_half = judged_lambda_half_m(in);
    size_t done = 0;
    std::string failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t f = 0; f < K; f++) {
        try {
            const std::vector<float> frames = to_unit(signals[f]);
            const double drive_s = static_cast<double>(frames.size() / channels) / rate_hz;
            engine::Simulation probe(in.plate, single_core_options(in));
            const size_t steps = probe.steps_for(drive_s + in.calibration.verify_tail_s);
            engine::Simulation sim = drive(in, exciters, frames, channels, rate_hz, steps);
            const double k = sim.time_step_s();
            FocusMetrics &m = v.foci[f];
            m.id = in.foci.points[f].id;
            m.at = in.foci.points[f].at;
            m.lambda_half_m = lambda_half;
            size_t peak_step = 0;
            for (size_t gi = 0; gi < K; gi++) {
                require_finite(sim.traces()[gi], "focus", in.foci.points[gi].id);
                for (size_t s = 0; s < sim.traces()[gi].size(); s++) {
                    const double a = std::abs(sim.traces()[gi][s]);
                    if (gi == f && a > m.peak_m) {
                        m.peak_m = a;
                        peak_step = s;
                    }
                    if (is_other_focus(in, f, gi, lambda_half))
                        m.max_other_foci_m = std::max(m.max_other_foci_m, a);
                }
            }
            m.lead_time_s = static_cast<double>(peak_step + 1) * k;
            v.traces[f] = sim.traces();
            if (snapshots) {
                // The field at the focus instant: run again to that step.
                engine::Simulation snap = drive(in, exciters, frames, channels, rate_hz, peak_step + 1);
                std::vector<double> field = snap.snapshot();
                v.snapshots[f].resize(field.size());
                for (size_t i = 0; i < field.size(); i++)
                    v.snapshots[f][i] = static_cast<float>(std::abs(field[i]));
                m.spot_diameter_m = spot_diameter(v.snapshots[f], g.nx, g.ny, g.h, m.at, m.peak_m / 2);
                for (int j = 0; j <= g.ny; j++)
                    for (int i = 0; i <= g.nx; i++)
                        if (dist(Point{i * g.h, j * g.h}, m.at) > lambda_half)
                            m.max_elsewhere_m =
                                std::max(m.max_elsewhere_m, static_cast<double>(v.snapshots[f][g.node(i, j)]));
                m.field_contrast_db = 20 * std::log10(m.peak_m / std::max(m.max_elsewhere_m, 1e-300));
            }
            bool others = false;
            for (size_t gi = 0; gi < K; gi++)
                others |= is_other_focus(in, f, gi, lambda_half);
            m.other_foci_contrast_db = others ? 20 * std::log10(m.peak_m / std::max(m.max_other_foci_m, 1e-300)) : 0.0;
            m.crosses_threshold = m.peak_m >= in.calibration.threshold_m;
            m.others_below_threshold = m.max_other_foci_m < in.calibration.threshold_m;
            if (f == 0)
                v.trace_rate_hz = 1.0 / k;
        } catch (const std::exception &ex) {
#pragma omp critical
            failure = "verification of focus " + std::to_string(in.foci.points[f].id) + ": " + ex.what();
        }
#pragma omp critical
        {
            done++;
            if (progress)
                progress("verify", done, K);
        }
    }
    if (!failure.empty())
        throw std::runtime_error(failure);
    return v;
}

Verification verify_drive_forward(const CalibrationInput &in, const std::vector<Point> &exciters,
                                  const std::vector<float> &frames, unsigned channels, double rate_hz,
                                  const ProgressFn &progress)
{
    if (channels != exciters.size())
        throw std::invalid_argument("drive has " + std::to_string(channels) + " channels for " +
                                    std::to_string(exciters.size()) + " exciters");
    const size_t K = in.foci.points.size();
    engine::Simulation probe(in.plate, single_core_options(in));
    const size_t steps =
        probe.steps_for(static_cast<double>(frames.size() / channels) / rate_hz + in.calibration.verify_tail_s);
    if (progress)
        progress("verify drive", 0, 1);
    engine::Simulation sim = drive(in, exciters, frames, channels, rate_hz, steps);
    Verification v;
    v.trace_rate_hz = 1.0 / sim.time_step_s();
    v.traces.push_back(sim.traces());
    v.foci.resize(K);
    for (size_t gi = 0; gi < K; gi++) {
        require_finite(sim.traces()[gi], "focus", in.foci.points[gi].id);
        FocusMetrics &m = v.foci[gi];
        m.id = in.foci.points[gi].id;
        m.at = in.foci.points[gi].at;
        m.lambda_half_m = judged_lambda_half_m(in);
        for (size_t s = 0; s < sim.traces()[gi].size(); s++)
            if (std::abs(sim.traces()[gi][s]) > m.peak_m) {
                m.peak_m = std::abs(sim.traces()[gi][s]);
                m.lead_time_s = static_cast<double>(s + 1) * sim.time_step_s();
            }
        m.crosses_threshold = m.peak_m >= in.calibration.threshold_m;
    }
    if (progress)
        progress("verify drive", 1, 1);
    return v;
}

} // namespace calib::pipeline
