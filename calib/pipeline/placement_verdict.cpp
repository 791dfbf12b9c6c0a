#include "pipeline/placement_verdict.h"

#include "engine/simulation.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/plan.h"
#include "pipeline/transfer/transfer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <string>
#include <tuple>

namespace calib::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// The ghosts that become probe rows: a focus's largest |w| beyond lambda/2
// reaching this fraction of the threshold (a focus that passes thinly today
// fails on the next placement, so its ghost is worth seeing), at most this
// many per round (placement_verdict.h), none within an eighth of a wavelength (a quarter of the
// judged radius) of a row the model has: the field's spatial peaks are about
// a quarter of the shortest wavelength wide, so a probe farther off misses
// the peak it was meant for (on Fig. 7, a quarter wavelength left the search
// at 5.6 dB with ghosts between the probes; an eighth reaches 6.3).
constexpr double ghost_fraction = 0.8;
constexpr double probe_spacing = 0.25; // of the judged radius (lambda/2)

// Per candidate site, its exciter's responses (one channel block of H),
// simulated the first time a placement uses the site.
class TransferCache {
  public:
    TransferCache(const CalibrationInput &in, const PlacementSearch &search) : in_(in), search_(search)
    {
        engine::Simulation probe(in.plate, single_core_options(in));
        options_ = transfer_options(in, probe.time_step_s());
        for (const FocusPoint &f : in.foci.points)
            foci_.push_back(f.at);
    }

    TransferMatrix matrix(const std::vector<std::size_t> &chosen, const ProgressFn &progress)
    {
        std::vector<std::size_t> missing;
        for (std::size_t i : chosen)
            if (!blocks_.count(i))
                missing.push_back(i);
        if (!missing.empty()) {
            TransferMatrix fresh = simulate_transfer(in_, search_.points(missing), foci_, options_,
                                                     [&](std::size_t done, std::size_t total) {
                                                         if (progress)
                                                             progress("transfer", done, total);
                                                     });
            const std::size_t block = fresh.point_count() * fresh.samples;
            for (std::size_t j = 0; j < missing.size(); j++)
                blocks_[missing[j]].assign(fresh.data.begin() + long(j * block),
                                           fresh.data.begin() + long((j + 1) * block));
            simulations_ += missing.size();
            if (shape_.samples == 0) {
                fresh.data.clear();
                shape_ = std::move(fresh);
            }
        }
        TransferMatrix H = shape_;
        H.channels = chosen.size();
        H.exciters = search_.points(chosen);
        const std::size_t block = H.point_count() * H.samples;
        H.data.resize(H.channels * block);
        for (std::size_t c = 0; c < chosen.size(); c++)
            std::copy(blocks_[chosen[c]].begin(), blocks_[chosen[c]].end(), H.data.begin() + long(c * block));
        return H;
    }
    std::size_t simulations() const { return simulations_; }

  private:
    const CalibrationInput &in_;
    const PlacementSearch &search_;
    TransferOptions options_;
    std::vector<Point> foci_;
    std::map<std::size_t, std::vector<float>> blocks_;
    TransferMatrix shape_;
    std::size_t simulations_ = 0;
};

// The ranking of placements (verdict_better), as a tuple compared in order.
using Rank = std::tuple<std::size_t, std::size_t, double>;
Rank rank_of(const PlacementReport::Judged &j) { return {j.passing_at_target, j.passing, j.worst_whole_area_db}; }

struct Trial {
    std::vector<std::size_t> chosen;
    CalibrationResult result;
    TransferMatrix H;
};

} // namespace

bool judged_by_verdict(const CalibrationInput &in, const PlacementSearch &search)
{
    return search.refinable() && transfer_holds(in) && in.exciters.verdict_rounds > 0;
}

std::size_t passing_at_target(const Verification &v, double amplitude_m)
{
    // The stored level is dithered: a focus within 1 % of the target reached it.
    std::size_t n = 0;
    for (const FocusMetrics &m : v.foci)
        n += m.passes() && m.peak_m >= 0.99 * amplitude_m;
    return n;
}

PlacementReport::Judged judged_figures(const Verification &v, double amplitude_m)
{
    const VerdictSummary s = summarize_verdict(v.foci);
    PlacementReport::Judged j;
    j.passing = s.passing;
    j.passing_at_target = passing_at_target(v, amplitude_m);
    j.worst_whole_area_db = s.total > 0 ? s.worst_margin_db : INFINITY;
    return j;
}

bool verdict_better(const Verification &a, const Verification &b, double amplitude_m)
{
    return rank_of(judged_figures(a, amplitude_m)) > rank_of(judged_figures(b, amplitude_m));
}

TransferMatrix search_by_verdict(const CalibrationInput &in, PlacementSearch &search, const ProgressFn &progress,
                                 CalibrationResult &res)
{
    const auto t0 = Clock::now();
    PlacementReport &pl = res.placement;
    TransferCache cache(in, search);
    const double thr = in.calibration.threshold_m;
    const double spacing = judged_lambda_half_m(in) * probe_spacing;
    const unsigned rounds = in.exciters.verdict_rounds;

    auto judge = [&](const std::vector<std::size_t> &chosen, bool regular) {
        Trial t;
        t.chosen = chosen;
        t.result.exciters = search.points(chosen);
        t.result.search_rate_hz = res.search_rate_hz;
        const auto t1 = Clock::now();
        t.H = cache.matrix(chosen, progress);
        t.result.times.transfer_s = seconds_since(t1);
        signals_and_verification(in, t.H, {}, t.result, true);
        PlacementReport::Judged j = judged_figures(t.result.verification, in.pulse.amplitude_m);
        j.chosen = chosen;
        j.proxy_db = search.proxy_db(chosen);
        j.probes = search.probes();
        j.regular = regular;
        pl.judged.push_back(j);
        if (progress)
            progress("verdict", pl.judged.size(), rounds + 2);
        return t;
    };

    Trial best = judge(pl.chosen, false);
    Trial last_searched = best;
    if (!pl.regular.empty() && pl.regular != pl.chosen) {
        Trial regular = judge(pl.regular, true);
        if (verdict_better(regular.result.verification, best.result.verification, in.pulse.amplitude_m))
            best = std::move(regular);
    }
    auto judged_before = [&](const std::vector<std::size_t> &c) {
        std::vector<std::size_t> a = c;
        std::sort(a.begin(), a.end());
        for (const PlacementReport::Judged &j : pl.judged) {
            std::vector<std::size_t> b = j.chosen;
            std::sort(b.begin(), b.end());
            if (a == b)
                return true;
        }
        return false;
    };
    for (unsigned round = 0; round < rounds; round++) {
        if (summarize_verdict(best.result.verification.foci).all_pass())
            break;
        // The ghosts of the last searched placement (what the model did not see), worst first.
        std::vector<std::pair<double, Point>> ghosts;
        for (const FocusMetrics &m : last_searched.result.verification.foci)
            if (m.whole_area && m.max_whole_area_m >= ghost_fraction * thr)
                ghosts.push_back({m.max_whole_area_m, m.whole_area_max_at});
        std::sort(ghosts.begin(), ghosts.end(), [](const auto &a, const auto &b) { return a.first > b.first; });
        std::vector<Point> probes;
        const std::size_t room = search.room(model_budget_bytes);
        for (const auto &[level, at] : ghosts) {
            bool seen = false;
            for (const Point &e : search.emitters())
                seen |= dist(e, at) < spacing;
            for (const Point &p : probes)
                seen |= dist(p, at) < spacing;
            if (!seen && probes.size() < std::min(ghosts_per_round, room))
                probes.push_back(at);
        }
        if (probes.empty())
            break;
        pl.ghost_probes.insert(pl.ghost_probes.end(), probes.begin(), probes.end());
        pl.probe_simulations += probes.size();
        const std::vector<std::size_t> next = search.refine(probes, best.chosen, progress);
        if (judged_before(next))
            break;
        last_searched = judge(next, false);
        if (verdict_better(last_searched.result.verification, best.result.verification, in.pulse.amplitude_m))
            best = last_searched;
    }

    // How often the foci-only proxy ranked two judged placements as the verdict did.
    for (std::size_t a = 0; a < pl.judged.size(); a++)
        for (std::size_t b = a + 1; b < pl.judged.size(); b++) {
            const PlacementReport::Judged &x = pl.judged[a], &y = pl.judged[b];
            if (rank_of(x) == rank_of(y))
                continue;
            pl.proxy_pairs++;
            pl.proxy_agreements += (x.proxy_db > y.proxy_db) == (rank_of(x) > rank_of(y));
        }

    const StageTimes searched = res.times;
    pl.chosen = best.chosen;
    pl.chosen_contrast_db = search.proxy_db(best.chosen);
    res.exciters = best.result.exciters;
    res.signals = std::move(best.result.signals);
    res.full_scale_peak_m = std::move(best.result.full_scale_peak_m);
    res.verification = std::move(best.result.verification);
    res.times = searched;
    res.times.transfer_s = best.result.times.transfer_s;
    res.times.signals_s = best.result.times.signals_s;
    res.times.verification_s = best.result.times.verification_s;
    pl.verdict_s = seconds_since(t0);
    res.times.verdict_s = pl.verdict_s;
    res.transfer = transfer_summary(best.H);
    return std::move(best.H);
}

std::vector<Point> placed_exciters(const CalibrationInput &in, const ProgressFn &progress)
{
    CalibrationResult res;
    PlacementSearch search(in, plan(in), progress, res);
    if (judged_by_verdict(in, search))
        (void)search_by_verdict(in, search, progress, res);
    return res.exciters;
}

} // namespace calib::pipeline
