#include "pipeline/calibrate.h"

#include "pipeline/plan.h"

#include "engine/effects/exciter.h"

#include <haptic_table.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

double dist(Point a, Point b) { return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m); }

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

// Every simulation of a calibration (impulse responses and verification):
// one core each, and the Mindlin engine when the scene asks for the thick
// plate (docs/effects.md). The finger is composed in drive() only.
engine::SimulationOptions single_thread(const CalibrationInput &in)
{
    engine::SimulationOptions o = in.simulation;
    o.engine.threads = 1;  // foci run in parallel; each simulation keeps to one core
    o.thick_plate = in.effects.thick_plate;
    return o;
}

// Node nearest to a point.
std::pair<int, int> nearest_node(const engine::Grid &g, Point p)
{
    const int i = std::clamp(static_cast<int>(std::lround(p.x_m / g.h)), 0, g.nx);
    const int j = std::clamp(static_cast<int>(std::lround(p.y_m / g.h)), 0, g.ny);
    return {i, j};
}

// Diameter of the circle with the area of the connected region around the
// focus node where |w| >= level.
double spot_diameter(const std::vector<float> &field, const engine::Grid &g, Point focus, double level)
{
    auto [i0, j0] = nearest_node(g, focus);
    const int w = g.nx + 1, h = g.ny + 1;
    std::vector<char> seen(field.size(), 0);
    std::vector<std::pair<int, int>> stack{{i0, j0}};
    size_t count = 0;
    while (!stack.empty()) {
        auto [i, j] = stack.back();
        stack.pop_back();
        if (i < 0 || j < 0 || i >= w || j >= h)
            continue;
        const size_t n = static_cast<size_t>(j) * w + i;
        if (seen[n] || field[n] < level)
            continue;
        seen[n] = 1;
        count++;
        stack.insert(stack.end(), {{i + 1, j}, {i - 1, j}, {i, j + 1}, {i, j - 1}});
    }
    return 2.0 * std::sqrt(static_cast<double>(count) * g.h * g.h / std::numbers::pi);
}

// Forces (N) at the simulation's rate from int16 drive samples at rate_hz.
std::vector<double> drive_force(const std::vector<float> &x_full_scale, double rate_hz, double sim_rate_hz,
                                double force_full_scale_n)
{
    std::vector<double> x(x_full_scale.begin(), x_full_scale.end());
    std::vector<double> y = resample(x, rate_hz, sim_rate_hz);
    for (double &v : y)
        v *= force_full_scale_n;
    return y;
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

void require_finite(const std::vector<double> &trace, const char *what, size_t index)
{
    for (size_t n = 0; n < trace.size(); n++)
        if (!std::isfinite(trace[n]))
            throw std::runtime_error(std::string(what) + " " + std::to_string(index) + ": non-finite displacement at step " +
                                     std::to_string(n) + " (the simulation diverged)");
}

}  // namespace

double a0_wavelength_m(const engine::PlateOperator &plate, double f_hz)
{
    return 2 * std::numbers::pi * std::sqrt(plate.kappa() / (2 * std::numbers::pi * f_hz));
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
    const Band band = band_of(in);
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
    PlacementReport &pl = res.placement;
    pl.band = plan.band;
    const double lambda = plan.lambda_centre_m;
    const bool fixed = in.exciters.placement == PlacementMode::fixed;
    pl.sites = plan.sites;

    // 1. One simulation per focus (and probe point): the pulse emitted there,
    //    recorded at every candidate site at once (reciprocity).
    const std::vector<Point> &emitters = plan.emitters;
    const size_t foci = plan.foci;
    for (size_t p = 0; p < plan.probes(); p++)
        pl.probe_rows.push_back(foci + p);

    const double rate_d = plan.search_rate_hz;
    res.search_rate_hz = rate_d;
    auto t0 = Clock::now();
    // Impulse responses h (a unit impulse at the emitter, band-limited by the
    // resampling to the stored rate) and pulse responses r = p * h.
    std::vector<std::vector<std::vector<float>>> responses(emitters.size());  // r [emitter][site][n]
    std::vector<std::vector<std::vector<float>>> impulse(emitters.size());    // h [emitter][site][n]
    const std::vector<double> pulse_d = sample_pulse(in.pulse, rate_d);
    size_t done = 0;
    std::string failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t e = 0; e < emitters.size(); e++) {
        try {
            engine::Simulation sim(in.plate, single_thread(in));
            const size_t src = sim.add_source(emitters[e].x_m, emitters[e].y_m);
            const double k = sim.time_step_s();
            sim.set_source_impulse(src);
            for (Point s : pl.sites)
                sim.add_receiver(s.x_m, s.y_m);
            sim.run(sim.steps_for(in.calibration.window_s));
            std::vector<std::vector<float>> rec(pl.sites.size()), imp(pl.sites.size());
            for (size_t i = 0; i < pl.sites.size(); i++) {
                require_finite(sim.traces()[i], "receiver", i);
                const std::vector<double> h = resample(sim.traces()[i], 1.0 / k, rate_d);
                imp[i].assign(h.begin(), h.end());
                rec[i].assign(h.size(), 0.0f);
                for (size_t n = 0; n < h.size(); n++) {  // r = p * h, causal, truncated to the window
                    double acc = 0;
                    for (size_t m = 0; m < pulse_d.size() && m <= n; m++)
                        acc += pulse_d[m] * h[n - m];
                    rec[i][n] = static_cast<float>(acc);
                }
            }
            responses[e] = std::move(rec);
            impulse[e] = std::move(imp);
        } catch (const std::exception &ex) {
#pragma omp critical
            failure = (e < foci ? "focus " + std::to_string(in.foci.points[e].id) : "probe " + std::to_string(e - foci)) +
                      ": " + ex.what();
        }
#pragma omp critical
        {
            done++;
            if (progress)
                progress("simulate", done, emitters.size());
        }
    }
    if (!failure.empty())
        throw std::runtime_error(failure);
    res.times.simulation_s = seconds_since(t0);

    // 2. Placement.
    t0 = Clock::now();
    const size_t n = responses[0][0].size();
    const auto keep = static_cast<size_t>(std::llround(in.calibration.truncate_fraction * static_cast<double>(n)));
    auto points_of = [&](const std::vector<size_t> &idx) {
        std::vector<Point> v;
        for (size_t i : idx)
            v.push_back(pl.sites[i]);
        return v;
    };
    const double variety_tol = lambda / 50;
    if (fixed) {
        for (size_t i = 0; i < pl.sites.size(); i++)
            pl.chosen.push_back(i);
    } else {
        pl.regular = regular_pattern(pl.band, pl.sites, in.exciters.count);
        pl.regular_variety = distance_variety(points_of(pl.regular), variety_tol);
    }
    std::unique_ptr<ContrastModel> model;
    if (emitters.size() >= 2)
        model = std::make_unique<ContrastModel>(
            responses, impulse, foci, keep,
            in.exciters.contrast_at_focus_instant
                ? static_cast<size_t>(std::ceil(pulse_duration_s(in.pulse) * rate_d))
                : 0);
    SearchOptions so;
    so.count = in.exciters.count;
    so.min_spacing_m = in.exciters.min_spacing_m;
    so.seed = in.exciters.seed;
    so.restarts = in.exciters.restarts;
    so.iterations = in.exciters.iterations;
    so.local_radius_m = lambda / 2;
    so.first_start = pl.regular;
    if (in.exciters.placement == PlacementMode::regular) {
        pl.chosen = pl.regular;
    } else if (in.exciters.placement == PlacementMode::random) {
        if (progress)
            progress("search", 0, 1);
        SearchResult r;
        if (in.exciters.criterion == PlacementCriterion::contrast && model) {
            r = search_placement_contrast(pl.sites, so, *model);
        } else {
            so.temperature_start = 0.05;
            so.temperature_end = 1e-4;
            r = search_placement(pl.sites, so, [&](const std::vector<size_t> &c) {
                return distance_variety(points_of(c), variety_tol);
            });
        }
        pl.chosen = r.chosen;
        pl.evaluations = r.evaluations;
    }
    pl.chosen_variety = distance_variety(points_of(pl.chosen), variety_tol);
    if (model) {
        pl.chosen_contrast_db = model->score(pl.chosen).worst_db;
        if (!pl.regular.empty())
            pl.regular_contrast_db = model->score(pl.regular).worst_db;
    }
    res.exciters = points_of(pl.chosen);
    res.times.search_s = seconds_since(t0);

    // 3. Time-reversal signals from the recordings at the chosen sites.
    t0 = Clock::now();
    TimeReversalOptions tro;
    tro.truncate_fraction = in.calibration.truncate_fraction;
    tro.output_rate_hz = in.calibration.output_rate_hz;
    tro.dither = in.calibration.dither;
    for (size_t f = 0; f < foci; f++) {
        std::vector<std::vector<double>> rec;
        for (size_t i : pl.chosen)
            rec.emplace_back(responses[f][i].begin(), responses[f][i].end());
        tro.dither_seed = in.exciters.seed * 1000003u + f;
        try {
            res.signals.push_back(make_drive_signals(rec, rate_d, pulse_duration_s(in.pulse), tro));
        } catch (const std::invalid_argument &e) {
            throw std::runtime_error("focus " + std::to_string(in.foci.points[f].id) + ": " + e.what());
        }
        if (in.effects.exciter && in.effects.exciter->precompensate)
            precompensate_for_exciter(res.signals.back(), *in.effects.exciter, tro);
    }
    responses.clear();
    responses.shrink_to_fit();
    impulse.clear();
    impulse.shrink_to_fit();
    res.times.signals_s = seconds_since(t0);

    // 4. Playback level: each focus is stored at the level that gives the
    //    scene's target amplitude (never above full scale), so the device plays
    //    the pulse the scene asks for. Linearity gives that level from one
    //    forward run at full scale.
    t0 = Clock::now();
    auto quantized = [&] {
        std::vector<std::vector<int16_t>> q;
        for (const DriveSignals &d : res.signals)
            q.push_back(d.samples);
        return q;
    };
    for (const VerificationPass &pass : plan.verification) {
        Verification v = verify_signals(in, res.exciters, quantized(), in.calibration.output_rate_hz, progress,
                                        pass.snapshots);
        if (!pass.sets_level) {  // 5. Verification with the signals exactly as the table stores them.
            res.verification = std::move(v);
            continue;
        }
        for (size_t f = 0; f < foci; f++) {
            res.full_scale_peak_m.push_back(v.foci[f].peak_m);
            if (!(v.foci[f].peak_m > 0))
                throw std::runtime_error("focus " + std::to_string(in.foci.points[f].id) +
                                         ": the exciters produce no displacement there");
            tro.dither_seed = in.exciters.seed * 1000003u + f;
            requantize(res.signals[f], std::min(1.0, in.pulse.amplitude_m / v.foci[f].peak_m), tro);
        }
    }
    res.times.verification_s = seconds_since(t0);
    return res;
}

namespace {

// Drives the exciters with forces from `frames` ([n][c], full scale 1.0) for
// `steps` steps, recording every focus.
engine::Simulation drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                         const std::vector<float> &frames, unsigned channels, double rate_hz, size_t steps)
{
    engine::Simulation sim(in.plate, single_thread(in));
    const double k = sim.time_step_s();
    const size_t n = frames.size() / channels;
    for (unsigned c = 0; c < channels; c++) {
        std::vector<float> ch(n);
        for (size_t i = 0; i < n; i++)
            ch[i] = frames[i * channels + c];
        const size_t src = sim.add_source(exciters[c].x_m, exciters[c].y_m);
        std::vector<double> force = drive_force(ch, rate_hz, 1.0 / k, in.exciters.force_full_scale_n);
        if (in.effects.exciter)  // the drive is Bl i; the plate gets the exciter's blocked force
            force = engine::effects::blocked_force(force, 1.0 / k, *in.effects.exciter);
        sim.set_source_signal(src, std::move(force));
    }
    for (const FocusPoint &f : in.foci.points)
        sim.add_receiver(f.at.x_m, f.at.y_m);
    if (in.effects.finger)  // playback: the finger presses while the signals play, not during calibration
        sim.add_finger(*in.effects.finger);
    sim.run(steps);
    return sim;
}

std::vector<float> to_unit(const std::vector<int16_t> &s)
{
    std::vector<float> v(s.size());
    for (size_t i = 0; i < s.size(); i++)
        v[i] = static_cast<float>(s[i]) / 32767.0f;
    return v;
}

}  // namespace

Verification verify_signals(const CalibrationInput &in, const std::vector<Point> &exciters,
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
    const double lambda_half = a0_wavelength_m(*in.plate, in.pulse.centre_hz) / 2;
    size_t done = 0;
    std::string failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t f = 0; f < K; f++) {
        try {
            const std::vector<float> frames = to_unit(signals[f]);
            const double drive_s = static_cast<double>(frames.size() / channels) / rate_hz;
            engine::Simulation probe(in.plate, single_thread(in));
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
                    if (gi != f)
                        m.max_other_foci_m = std::max(m.max_other_foci_m, a);
                }
            }
            m.peak_time_s = static_cast<double>(peak_step + 1) * k;
            v.traces[f] = sim.traces();
            if (snapshots) {
                // The field at the focus instant: run again to that step.
                engine::Simulation snap = drive(in, exciters, frames, channels, rate_hz, peak_step + 1);
                std::vector<double> field = snap.snapshot();
                v.snapshots[f].resize(field.size());
                for (size_t i = 0; i < field.size(); i++)
                    v.snapshots[f][i] = static_cast<float>(std::abs(field[i]));
                m.spot_diameter_m = spot_diameter(v.snapshots[f], g, m.at, m.peak_m / 2);
                for (int j = 0; j <= g.ny; j++)
                    for (int i = 0; i <= g.nx; i++)
                        if (std::hypot(i * g.h - m.at.x_m, j * g.h - m.at.y_m) > lambda_half)
                            m.max_elsewhere_m = std::max(m.max_elsewhere_m,
                                                         static_cast<double>(v.snapshots[f][g.node(i, j)]));
                m.field_contrast_db = 20 * std::log10(m.peak_m / std::max(m.max_elsewhere_m, 1e-300));
            }
            m.contrast_db = K > 1 ? 20 * std::log10(m.peak_m / std::max(m.max_other_foci_m, 1e-300)) : 0.0;
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

Verification verify_drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                          const std::vector<float> &frames, unsigned channels, double rate_hz,
                          const ProgressFn &progress)
{
    if (channels != exciters.size())
        throw std::invalid_argument("drive has " + std::to_string(channels) + " channels for " +
                                    std::to_string(exciters.size()) + " exciters");
    const size_t K = in.foci.points.size();
    engine::Simulation probe(in.plate, single_thread(in));
    const size_t steps = probe.steps_for(static_cast<double>(frames.size() / channels) / rate_hz +
                                         in.calibration.verify_tail_s);
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
        m.lambda_half_m = a0_wavelength_m(*in.plate, in.pulse.centre_hz) / 2;
        for (size_t s = 0; s < sim.traces()[gi].size(); s++)
            if (std::abs(sim.traces()[gi][s]) > m.peak_m) {
                m.peak_m = std::abs(sim.traces()[gi][s]);
                m.peak_time_s = static_cast<double>(s + 1) * sim.time_step_s();
            }
        m.crosses_threshold = m.peak_m >= in.calibration.threshold_m;
    }
    if (progress)
        progress("verify drive", 1, 1);
    return v;
}

void write_table(const std::string &path, const CalibrationInput &in, const CalibrationResult &r)
{
    const size_t K = r.signals.size(), C = r.exciters.size();
    size_t frames = 0;
    for (const DriveSignals &d : r.signals)
        frames = std::max(frames, d.frames);
    std::vector<double> cxy, fxy, scale, lead;
    std::vector<uint32_t> ids;
    for (Point p : r.exciters)
        cxy.insert(cxy.end(), {p.x_m, p.y_m});
    std::vector<int16_t> samples(K * frames * C, 0);
    for (size_t f = 0; f < K; f++) {
        const FocusMetrics &m = r.verification.foci[f];
        if (!(m.peak_m > 0) || !std::isfinite(m.peak_m))
            throw std::runtime_error("focus " + std::to_string(m.id) + ": verification found no displacement");
        ids.push_back(in.foci.points[f].id);
        fxy.insert(fxy.end(), {in.foci.points[f].at.x_m, in.foci.points[f].at.y_m});
        scale.push_back(m.peak_m);
        lead.push_back(m.peak_time_s);  // same forward run as scale_m: the stored samples at gain 1
        std::copy(r.signals[f].samples.begin(), r.signals[f].samples.end(), samples.begin() + f * frames * C);
    }
    char created[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(created, sizeof created, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    const std::string tool = "calibgen " HAPTIC_VERSION;
    std::string name = in.scene_name.substr(0, HAPTIC_TABLE_SCENE_NAME_LEN);
    while (!name.empty() && name.size() < in.scene_name.size() &&
           (static_cast<unsigned char>(in.scene_name[name.size()]) & 0xC0) == 0x80)
        name.pop_back();  // never cut a UTF-8 sequence: the reader refuses invalid UTF-8
    haptic_table_spec spec{};
    spec.sample_rate_hz = static_cast<uint32_t>(std::lround(in.calibration.output_rate_hz));
    spec.channel_count = static_cast<uint16_t>(C);
    spec.focus_count = static_cast<uint32_t>(K);
    spec.samples_per_signal = static_cast<uint32_t>(frames);
    spec.channel_xy_m = cxy.data();
    spec.focus_id = ids.data();
    spec.focus_xy_m = fxy.data();
    spec.focus_scale_m = scale.data();
    spec.samples = samples.data();
    spec.scene_name = name.c_str();
    spec.scene_hash = in.scene_hash.c_str();
    spec.tool_version = tool.c_str();
    spec.created_utc = created;
    // What a count means (drive() in this file): force_full_scale_n at 32767,
    // through the exciter's response when the scene models the exciter.
    spec.drive_kind = !in.effects.exciter                 ? HAPTIC_DRIVE_FORCE
                      : in.effects.exciter->precompensate ? HAPTIC_DRIVE_EXCITER_PRECOMPENSATED
                                                          : HAPTIC_DRIVE_EXCITER;
    spec.force_full_scale_n = in.exciters.force_full_scale_n;
    spec.focus_lead_time_s = lead.data();
    haptic_table_error err{};
    if (haptic_table_write(path.c_str(), &spec, &err) != 0)
        throw std::runtime_error(path + ": " + err.message);
}

}  // namespace calib::pipeline
