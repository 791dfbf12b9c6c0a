#include "pipeline/placement_search.h"

#include "engine/lanes.h"
#include "io/format.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/placement/placement.h"
#include "pipeline/placement/site_recording.h"
#include "pipeline/signal/first_failure.h"
#include "pipeline/signal/pulse.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

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
    return io::fmt("focus at (%g, %g) m", p.x_m, p.y_m);
}

} // namespace

namespace {

// Per emitter, the pulse responses r and the impulse responses h at every
// candidate site: one reciprocity simulation each (record_sites_of: side by
// side in the engine's lanes where the plate allows), in parallel.
struct EmitterResponses {
    std::vector<std::vector<std::vector<float>>> pulse, impulse; // [emitter][site][n]
    double responses_s = 0; // of the whole: the recordings resampled and convolved with the pulse
};

EmitterResponses simulate_emitters(const CalibrationInput &in, const std::vector<Point> &emitters,
                                   const std::vector<Point> &sites, double rate_d, std::size_t foci,
                                   const std::string &stage, const ProgressFn &progress)
{
    EmitterResponses out;
    out.pulse.resize(emitters.size());
    out.impulse.resize(emitters.size());
    const std::vector<double> pulse_d = sample_pulse(in.pulse, rate_d);
    const engine::SimulationOptions options = single_core_options(in);
    engine::Simulation probe(in.plate, options);
    const double k = probe.time_step_s();
    const std::size_t steps = probe.steps_for(in.calibration.window_s);
    auto name = [&](std::size_t e) {
        return e < foci ? focus_name(in, emitters[e]) : "probe " + std::to_string(e - foci);
    };
    std::vector<SiteRecording> recordings;
    try {
        recordings = record_sites_of(in.plate, options, emitters, sites, steps, site_recording_options(k, rate_d),
                                     [&](std::size_t done, std::size_t total) {
                                         if (progress)
                                             progress(stage, done, total);
                                     });
    } catch (const engine::SourceFailure &ex) {
        throw std::runtime_error(name(ex.source()) + ": " + ex.what());
    }
    const auto t0 = Clock::now();
    FirstFailure failure;
#pragma omp parallel for schedule(dynamic)
    for (size_t e = 0; e < emitters.size(); e++) {
        try {
            const std::vector<std::vector<double>> resampled = site_responses_at(recordings[e], k, steps, rate_d);
            std::vector<std::vector<float>> rec(sites.size()), imp(sites.size());
            for (size_t i = 0; i < sites.size(); i++) {
                const std::vector<double> &h = resampled[i];
                require_finite(h, i);
                imp[i].assign(h.begin(), h.end());
                rec[i].assign(h.size(), 0.0f);
                for (size_t n = 0; n < h.size(); n++) { // r = p * h, causal, truncated to the window
                    double acc = 0;
                    for (size_t m = 0; m < pulse_d.size() && m <= n; m++)
                        acc += pulse_d[m] * h[n - m];
                    rec[i][n] = static_cast<float>(acc);
                }
            }
            out.pulse[e] = std::move(rec);
            out.impulse[e] = std::move(imp);
        } catch (const std::exception &ex) {
            failure.keep(e, name(e) + ": " + ex.what());
        }
    }
    failure.rethrow();
    out.responses_s = seconds_since(t0);
    return out;
}

} // namespace

struct PlacementSearch::State {
    EmitterResponses responses;
    std::vector<Point> emitters; // the foci of the subset, then the probe points
    std::size_t foci = 0;
    std::size_t keep = 0, half_window = 0;
    std::unique_ptr<ContrastModel> model;
    std::size_t first_rows = 0; // the plan's emitters: the rows of the proxy the verdict is compared with
    SearchOptions options;
};

PlacementSearch::~PlacementSearch() = default;

PlacementSearch::PlacementSearch(const CalibrationInput &in, const CalibrationPlan &plan, const ProgressFn &progress,
                                 CalibrationResult &res)
    : in_(in), state_(std::make_unique<State>())
{
    State &st = *state_;
    PlacementReport &pl = res.placement;
    pl.band = plan.band;
    const double lambda = plan.lambda_centre_m;
    const bool fixed = in.exciters.placement == PlacementMode::fixed;
    pl.sites = plan.sites;
    sites_ = plan.sites;
    lambda_half_m_ = judged_lambda_half_m(in);

    // 1. One simulation per focus (and probe point): the pulse emitted there,
    //    recorded at every candidate site at once (reciprocity).
    st.emitters = plan.emitters;
    st.foci = plan.foci; // the emitters that are foci (of the placement subset)
    for (size_t p = 0; p < plan.probes(); p++)
        pl.probe_rows.push_back(st.foci + p);

    rate_d_ = plan.search_rate_hz;
    res.search_rate_hz = rate_d_;
    auto t0 = Clock::now();
    st.responses = simulate_emitters(in, st.emitters, pl.sites, rate_d_, st.foci, "simulate", progress);
    res.times.simulation_s = seconds_since(t0);
    res.times.site_responses_s = st.responses.responses_s;

    // 2. Placement.
    t0 = Clock::now();
    const size_t n = st.responses.pulse[0][0].size();
    st.keep = static_cast<size_t>(std::llround(kept_fraction(in) * static_cast<double>(n)));
    st.half_window = in.exciters.contrast_at_focus_instant
                         ? static_cast<size_t>(std::ceil(pulse_duration_s(in.pulse) * rate_d_))
                         : 0;
    const double variety_tol = lambda / 50;
    if (fixed) {
        for (size_t i = 0; i < pl.sites.size(); i++)
            pl.chosen.push_back(i);
    } else {
        pl.regular = regular_pattern(pl.band, pl.sites, in.exciters.count);
        pl.regular_variety = distance_variety(points(pl.regular), variety_tol);
    }
    st.first_rows = st.emitters.size();
    if (st.emitters.size() >= 2)
        st.model =
            std::make_unique<ContrastModel>(st.responses.pulse, st.responses.impulse, st.foci, st.keep, st.half_window);
    SearchOptions &so = st.options;
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
        if (in.exciters.criterion == PlacementCriterion::contrast && st.model) {
            r = search_placement_contrast(pl.sites, so, *st.model);
            refinable_ = true;
        } else {
            so.temperature_start = 0.05;
            so.temperature_end = 1e-4;
            r = search_placement(
                pl.sites, so, [&](const std::vector<size_t> &c) { return distance_variety(points(c), variety_tol); });
        }
        pl.chosen = r.chosen;
        pl.evaluations = r.evaluations;
    }
    pl.chosen_variety = distance_variety(points(pl.chosen), variety_tol);
    if (st.model) {
        pl.chosen_contrast_db = st.model->score(pl.chosen).worst_db;
        if (!pl.regular.empty())
            pl.regular_contrast_db = st.model->score(pl.regular).worst_db;
    }
    res.exciters = points(pl.chosen);
    res.times.search_s = seconds_since(t0);
}

std::vector<Point> PlacementSearch::points(const std::vector<size_t> &chosen) const
{
    std::vector<Point> v;
    for (size_t i : chosen)
        v.push_back(sites_[i]);
    return v;
}

std::size_t PlacementSearch::probes() const { return state_->emitters.size() - state_->foci; }

double PlacementSearch::proxy_db(const std::vector<size_t> &chosen) const
{
    return state_->model ? state_->model->score(chosen, state_->first_rows).worst_db : 0.0;
}

std::size_t PlacementSearch::room(double bytes) const
{
    const ContrastModel *m = state_->model.get();
    if (!m || m->row_bytes() == 0 || bytes <= double(m->bytes()))
        return 0;
    return static_cast<std::size_t>((bytes - double(m->bytes())) / double(m->row_bytes()));
}

const std::vector<Point> &PlacementSearch::emitters() const { return state_->emitters; }

std::vector<size_t> PlacementSearch::refine(const std::vector<Point> &probes, const std::vector<size_t> &start,
                                            const ProgressFn &progress)
{
    State &st = *state_;
    EmitterResponses add = simulate_emitters(in_, probes, sites_, rate_d_, 0, "ghost probes", progress);
    for (size_t e = 0; e < probes.size(); e++) {
        st.emitters.push_back(probes[e]);
        st.responses.pulse.push_back(std::move(add.pulse[e]));
        st.responses.impulse.push_back(std::move(add.impulse[e]));
    }
    // A probe within lambda/2 of a focus lies in that focus's own spot: it
    // does not count against it (the verdict's rule).
    st.model->add_rows(st.responses.pulse, st.responses.impulse);
    for (size_t f = 0; f < st.foci; f++)
        for (size_t g = st.foci; g < st.emitters.size(); g++)
            if (dist(st.emitters[f], st.emitters[g]) <= lambda_half_m_)
                st.model->ignore(f, g);
    SearchOptions so = st.options;
    so.first_start = start;
    // Half the restarts: the first starts from the best placement so far, the
    // others explore (on Fig. 7 as good as all of them, at half the time).
    so.restarts = std::max(1u, so.restarts / 2);
    if (progress)
        progress("search", 0, 1);
    std::vector<size_t> chosen = search_placement_contrast(sites_, so, *st.model).chosen;
    if (progress)
        progress("search", 1, 1);
    return chosen;
}

} // namespace calib::pipeline
