// Stages 1 and 2 of a calibration: the responses of the placement's emitters
// (one reciprocity simulation each: the pulse emitted at a focus of the
// placement subset, or a probe point, recorded at every candidate exciter
// site at once) and the placement search over them.
#include "pipeline/calibrate_stages.h"
#include "pipeline/lead_time.h"

#include "pipeline/plan.h"
#include "pipeline/site_recording.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
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

void require_finite(const std::vector<double> &trace, size_t index)
{
    for (size_t n = 0; n < trace.size(); n++)
        if (!std::isfinite(trace[n]))
            throw std::runtime_error("site " + std::to_string(index) + ": non-finite displacement at sample " +
                                     std::to_string(n) + " (the simulation diverged)");
}

// "focus <id>" of the scene focus at p (the placement's emitters are foci of the scene).
std::string focus_name(const CalibrationInput &in, Point p)
{
    for (const FocusPoint &f : in.foci.points)
        if (f.at.x_m == p.x_m && f.at.y_m == p.y_m)
            return "focus " + std::to_string(f.id);
    return "focus at (" + fmt(p.x_m) + ", " + fmt(p.y_m) + ") m";
}

}  // namespace

void place_exciters(const CalibrationInput &in, const CalibrationPlan &plan, const ProgressFn &progress,
                    CalibrationResult &res)
{
    PlacementReport &pl = res.placement;
    pl.band = plan.band;
    const double lambda = plan.lambda_centre_m;
    const bool fixed = in.exciters.placement == PlacementMode::fixed;
    pl.sites = plan.sites;

    // 1. One simulation per focus (and probe point): the pulse emitted there,
    //    recorded at every candidate site at once (reciprocity).
    const std::vector<Point> &emitters = plan.emitters;
    const size_t foci = plan.foci;  // the emitters that are foci (of the placement subset)
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
            engine::Simulation sim(in.plate, single_core_options(in));
            const double k = sim.time_step_s();
            const std::size_t steps = sim.steps_for(in.calibration.window_s);
            const SiteRecording sites = record_sites(sim, emitters[e], pl.sites, steps,
                                                     site_recording_options(k, rate_d));
            const std::vector<std::vector<double>> resampled = site_responses_at(sites, k, steps, rate_d);
            std::vector<std::vector<float>> rec(pl.sites.size()), imp(pl.sites.size());
            for (size_t i = 0; i < pl.sites.size(); i++) {
                const std::vector<double> &h = resampled[i];
                require_finite(h, i);
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
            failure = (e < foci ? focus_name(in, emitters[e]) : "probe " + std::to_string(e - foci)) +
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
    const auto keep = static_cast<size_t>(std::llround(kept_fraction(in) * static_cast<double>(n)));
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

}

}  // namespace calib::pipeline
