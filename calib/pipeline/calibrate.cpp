#include "pipeline/calibrate.h"
#include "pipeline/radiation.h"

#include "pipeline/calibrate_stages.h"
#include "pipeline/first_failure.h"
#include "pipeline/inverse_filter.h"
#include "pipeline/placement_verdict.h"
#include "pipeline/lead_time.h"
#include "pipeline/plan.h"
#include "pipeline/robust.h"
#include "pipeline/verification.h"

#include "engine/effects/exciter.h"

#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }


std::string fmt(double v)
{
    char b[32];
    std::snprintf(b, sizeof b, "%g", v);
    return b;
}

// A0 group velocity (Kirchhoff: twice the phase velocity sqrt(omega kappa)).
double a0_group_velocity(const engine::PlateOperator &plate, double f_hz)
{
    return 2.0 * std::sqrt(2 * std::numbers::pi * f_hz * plate.kappa());
}

}  // namespace

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

double a0_wavelength_m(const engine::PlateOperator &plate, double f_hz)
{
    return 2 * std::numbers::pi * std::sqrt(plate.kappa() / (2 * std::numbers::pi * f_hz));
}

double judged_lambda_half_m(const CalibrationInput &in)
{
    return in.lambda_half_m > 0 ? in.lambda_half_m : a0_wavelength_m(*in.plate, in.pulse.centre_hz) / 2;
}

std::string scene_hash(const std::string &bytes)
{
    const uLong c = crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef *>(bytes.data()),
                          static_cast<uInt>(bytes.size()));
    char b[32];
    std::snprintf(b, sizeof b, "crc32:%08lx", static_cast<unsigned long>(c));
    return b;
}

void check_feasible(const CalibrationInput &in)
{
    const auto &pp = in.plate->params();
    const double lx = pp.size_x_m, ly = pp.size_y_m;
    if (in.foci.points.empty())
        throw std::invalid_argument("foci: no focus points");
    for (size_t k = 0; k < in.foci.points.size(); k++) {
        const Point p = in.foci.points[k].at;
        if (!(p.x_m > 0 && p.x_m < lx && p.y_m > 0 && p.y_m < ly))
            throw std::invalid_argument("foci: focus " + std::to_string(in.foci.points[k].id) + " at (" + fmt(p.x_m) +
                                        ", " + fmt(p.y_m) + ") m is not inside the plate (0..." + fmt(lx) + ", 0..." +
                                        fmt(ly) + ")");
    }
    // Foci are where a person touches: inside the active area.
    const Rect &area = in.active.area;
    for (size_t k = 0; k < in.foci.points.size(); k++) {
        const Point p = in.foci.points[k].at;
        if (!area.contains(p, 1e-9))
            throw std::invalid_argument("foci.points_m: focus " + std::to_string(in.foci.points[k].id) + " at (" +
                                        fmt(p.x_m) + ", " + fmt(p.y_m) + ") m is outside the active area [" +
                                        fmt(area.x0_m) + ", " + fmt(area.y0_m) + ", " + fmt(area.x1_m) + ", " +
                                        fmt(area.y1_m) + "]");
    }
    // Foci closer than one cell of the plate grid are not distinct points of
    // the simulated plate (the source and receiver of each sit on its nodes).
    const double h = in.plate->grid().h;
    if (in.foci.pitch_m && *in.foci.pitch_m < h)
        throw std::invalid_argument("foci.pitch_m: " + fmt(*in.foci.pitch_m) +
                                    " m is finer than the simulation grid spacing (" + fmt(h) +
                                    " m): foci closer than one grid cell are not distinct on the simulated plate");
    const Rect &a = in.active.area;
    if (!(a.x0_m < a.x1_m && a.y0_m < a.y1_m && a.x0_m >= 0 && a.y0_m >= 0 && a.x1_m <= lx && a.y1_m <= ly))
        throw std::invalid_argument("active_area: the rectangle must lie on the plate with x0 < x1 and y0 < y1");
    const double crossing = std::hypot(lx, ly) / a0_group_velocity(*in.plate, in.pulse.centre_hz);
    if (in.calibration.window_s < crossing)
        throw std::invalid_argument("calibration.window_s: " + fmt(in.calibration.window_s) +
                                    " s is shorter than one crossing of the plate (" + fmt(crossing) +
                                    " s along the diagonal at the A0 group velocity)");
    if (in.calibration.window_s * in.calibration.truncate_fraction < pulse_duration_s(in.pulse))
        throw std::invalid_argument("calibration.truncate_fraction: the kept part of the window is shorter than the pulse");
    if (in.tolerance)
        check_tolerance(in, *in.tolerance);
    if (in.robust)
        ensemble_members(in, *in.robust);  // refuses members the scheme cannot take
    const Band band = band_of(in);
    check_lead_time(in, in.exciters.placement == PlacementMode::fixed ? in.exciters.positions : plan(in).sites);
    if (in.exciters.placement == PlacementMode::fixed) {
        if (in.exciters.positions.size() != in.exciters.count)
            throw std::invalid_argument("exciters.positions: " + std::to_string(in.exciters.positions.size()) +
                                        " positions for exciters.count = " + std::to_string(in.exciters.count));
        for (size_t k = 0; k < in.exciters.positions.size(); k++)
            if (!band.allows(in.exciters.positions[k]))
                throw std::invalid_argument("exciters.positions[" + std::to_string(k) +
                                            "]: inside the active area, its clearance or the frame margin");
        return;
    }
    const std::vector<Point> sites = plan(in).sites;
    // Greedy packing at the minimum spacing: if it cannot place them, no search can.
    std::vector<Point> placed;
    for (Point s : sites) {
        bool ok = true;
        for (Point p : placed)
            ok &= dist(p, s) >= in.exciters.min_spacing_m;
        if (ok)
            placed.push_back(s);
    }
    if (placed.size() < in.exciters.count)
        throw std::invalid_argument("exciters.count: the border band (frame_margin_m, clearance_m around the active "
                                    "area) holds only " + std::to_string(placed.size()) + " exciters " +
                                    fmt(in.exciters.min_spacing_m) + " m apart, " +
                                    std::to_string(in.exciters.count) + " asked");
}

CalibrationResult calibrate(const CalibrationInput &in, const ProgressFn &progress)
{
    check_feasible(in);
    const CalibrationPlan plan = pipeline::plan(in);
    CalibrationResult res;

    // 1-2. Responses of the placement's emitters (the foci of its subset and
    //      any probe points) and the placement search.
    PlacementSearch search(in, plan, progress, res);
    res.placement.focus_subset = plan.focus_subset;
    res.placement.subset_cover_m = plan.subset_cover_m;
    res.placement.simulations = plan.emitters.size();

    // 2-5. A searched placement is judged by the verdict of its own drives
    //      (placement_verdict.h): the transfer matrix, signals and
    //      verification of the best one judged stay.
    if (judged_by_verdict(in, search)) {
        const TransferMatrix H = search_by_verdict(in, search, progress, res);
        if (in.robust)  // the robust design of the placement the plain design chose
            signals_and_verification(in, H, progress, res);
        else
            finish_stages(in, H, progress, res);
        return res;
    }

    // 3. The transfer matrix of the placed exciters (the finger is composed in
    //    playback only, so H of the bare plate also serves the finger's scenes).
    auto t0 = Clock::now();
    const TransferMatrix H = transfer_for(in, res.exciters, progress);
    res.transfer = {H.channels, H.lattice.size(), H.point_count() - H.lattice.size(), H.samples,
                    H.rate_hz,  H.lattice.spacing_m, H.bytes()};
    res.times.transfer_s = seconds_since(t0);

    // 4-5. Drive signals from H, their level and the verification.
    signals_and_verification(in, H, progress, res);
    return res;
}

void signals_and_verification(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                              CalibrationResult &res, bool judge_only)
{
    // 4. Drive signals from H: time reversal or the inverse filter.
    auto t0 = Clock::now();
    TimeReversalOptions tro;
    tro.truncate_fraction = in.calibration.truncate_fraction;
    tro.output_rate_hz = in.calibration.output_rate_hz;
    tro.dither = in.calibration.dither;
    res.signals = in.calibration.method == DriveMethod::inverse_filter ? inverse_filter_signals(in, H, progress)
                                                                      : signals_from_transfer(in, H);
    // A robust design (the same method over the ensemble of plates) replaces
    // them; the plain design stays for the comparison.
    std::vector<DriveSignals> plain;
    std::optional<RobustDesign> robust;
    if (in.robust && !judge_only) {
        robust = robust_design(in, H, progress);
        plain = std::move(res.signals);
        res.signals = robust->signals;
    }
    if (in.effects.exciter && in.effects.exciter->precompensate)
        for (size_t f = 0; f < res.signals.size(); f++) {
            tro.dither_seed = in.exciters.seed * 1000003u + f;
            precompensate_for_exciter(res.signals[f], *in.effects.exciter, tro);
            if (f < plain.size())
                precompensate_for_exciter(plain[f], *in.effects.exciter, tro);
        }
    res.times.signals_s = seconds_since(t0);

    // 5. Playback level: each focus is stored at the level that gives the
    //    scene's target amplitude (never above full scale), so the device plays
    //    the pulse the scene asks for; linearity gives it from the full-scale
    //    peak. Then the verification of the signals exactly as stored.
    t0 = Clock::now();
    auto quantized = [&] {
        std::vector<std::vector<int16_t>> q;
        for (const DriveSignals &d : res.signals)
            q.push_back(d.samples);
        return q;
    };
    const bool lti = transfer_holds(in);
    res.full_scale_peak_m = lti ? focal_peaks(in, H, quantized(), in.calibration.output_rate_hz) : std::vector<double>{};
    if (!lti) {
        const Verification full = verify_signals_forward(in, res.exciters, quantized(), in.calibration.output_rate_hz,
                                                         progress, false);
        for (const FocusMetrics &m : full.foci)
            res.full_scale_peak_m.push_back(m.peak_m);
    }
    for (size_t f = 0; f < res.signals.size(); f++) {
        if (!(res.full_scale_peak_m[f] > 0))
            throw std::runtime_error("focus " + std::to_string(in.foci.points[f].id) +
                                     ": the exciters produce no displacement there");
        tro.dither_seed = in.exciters.seed * 1000003u + f;
        const double amplitude = robust && !robust->amplitude_m.empty() ? robust->amplitude_m[f] : in.pulse.amplitude_m;
        requantize(res.signals[f], std::min(1.0, amplitude / res.full_scale_peak_m[f]), tro);
    }
    const std::vector<std::vector<int16_t>> stored = quantized();  // as the table holds them
    res.verification = lti ? verify_signals_with(in, H, stored, in.calibration.output_rate_hz, progress)
                           : verify_signals_forward(in, res.exciters, stored, in.calibration.output_rate_hz,
                                                    progress, true);
    res.times.verification_s = seconds_since(t0);
    if (!judge_only)
        finish_stages(in, H, progress, res, std::move(plain), robust ? &*robust : nullptr);
}

void finish_stages(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                   CalibrationResult &res, std::vector<DriveSignals> plain, const RobustDesign *robust)
{
    // What a listener hears of each focus (pipeline/radiation.h): from H's lattice.
    if (transfer_holds(in) && H.lattice.size() > 0) {
        const auto t1 = Clock::now();
        std::vector<std::vector<int16_t>> stored;
        for (const DriveSignals &d : res.signals)
            stored.push_back(d.samples);
        const std::vector<RadiatedSound> sound = radiated_sounds(in, H, stored, in.calibration.output_rate_hz);
        for (size_t f = 0; f < res.verification.foci.size() && f < sound.size(); f++) {
            res.verification.foci[f].sound_exposure_dba = sound[f].exposure_level_dba;
            res.verification.foci[f].sound = true;
        }
        res.times.sound_s = seconds_since(t1);
        res.times.verification_s += res.times.sound_s;
    }

    // 6. The table over the scene's tolerance box (pipeline/robust.h).
    if (in.tolerance || in.robust)
        res.tolerance = tolerance_stage(in, H, res, std::move(plain), robust, progress);
}

std::vector<DriveSignals> signals_from_transfer(const CalibrationInput &in, const TransferMatrix &H)
{
    TimeReversalOptions tro;
    tro.truncate_fraction = in.calibration.truncate_fraction;
    tro.output_rate_hz = in.calibration.output_rate_hz;
    tro.dither = in.calibration.dither;
    const std::vector<double> pulse = sample_pulse(in.pulse, H.rate_hz);
    // The recording window at H's rate; only its kept part is non-zero in use,
    // and H covers it (transfer_options: the kept window and the tail).
    const auto n = static_cast<size_t>(std::llround(in.calibration.window_s * H.rate_hz));
    const auto keep = static_cast<size_t>(std::llround(kept_fraction(in) * double(n)));
    if (keep > H.samples)
        throw std::logic_error("transfer matrix shorter than the kept window");
    if (in.calibration.lead_time_s)  // the kept window the lead time asks for (lead_time.h)
        tro.truncate_fraction = double(keep) / double(n);
    // One focus per thread; each focus's dither seed is its own, so the
    // signals do not depend on the thread count.
    std::vector<DriveSignals> out(in.foci.points.size());
    FirstFailure failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t f = 0; f < in.foci.points.size(); f++) {
        std::vector<std::vector<double>> rec(H.channels, std::vector<double>(n, 0.0));
        for (size_t c = 0; c < H.channels; c++) {
            const float *h = H.response(c, H.exact_begin() + f);
            for (size_t t = 0; t < keep; t++) {  // r = p * h, causal
                double acc = 0;
                for (size_t m = 0; m < pulse.size() && m <= t; m++)
                    acc += pulse[m] * double(h[t - m]);
                rec[c][t] = acc;
            }
        }
        TimeReversalOptions o = tro;
        o.dither_seed = in.exciters.seed * 1000003u + f;
        try {
            out[f] = make_drive_signals(rec, H.rate_hz, pulse_duration_s(in.pulse), o);
        } catch (const std::exception &e) {
            failure.keep(f, "focus " + std::to_string(in.foci.points[f].id) + ": " + e.what());
        }
    }
    failure.rethrow();
    return out;
}

bool transfer_holds(const CalibrationInput &in) { return !in.effects.finger; }

engine::SimulationOptions single_core_options(const CalibrationInput &in)
{
    engine::SimulationOptions o = in.simulation;
    o.engine.threads = 1;  // the simulations run in parallel; each keeps to one core
    o.thick_plate = in.effects.thick_plate;
    return o;
}

Verification verify_signals(const CalibrationInput &in, const std::vector<Point> &exciters,
                            const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                            const ProgressFn &progress, bool whole_area)
{
    if (!transfer_holds(in))
        return verify_signals_forward(in, exciters, signals, rate_hz, progress, whole_area);
    return verify_signals_with(in, transfer_for(in, exciters, progress), signals, rate_hz, progress, whole_area);
}

Verification verify_drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                          const std::vector<float> &frames, unsigned channels, double rate_hz,
                          const ProgressFn &progress)
{
    if (channels != exciters.size())
        throw std::invalid_argument("drive has " + std::to_string(channels) + " channels for " +
                                    std::to_string(exciters.size()) + " exciters");
    if (!transfer_holds(in))
        return verify_drive_forward(in, exciters, frames, channels, rate_hz, progress);
    const TransferMatrix H = transfer_for(in, exciters, progress);
    if (progress)
        progress("verify drive", 0, 1);
    Verification v = verify_drive_with(in, H, frames, channels, rate_hz);
    if (progress)
        progress("verify drive", 1, 1);
    return v;
}
}  // namespace calib::pipeline
