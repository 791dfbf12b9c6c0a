// The placement search judged by the verdict (data/verdict.h FocusMetrics::passes).
//
// The contrast model (placement/placement.h) predicts, by reciprocity, the time-reversal
// field at the foci of the search's subset and at a few probe points: a proxy.
// What a person feels is the whole active area at all times, and there the
// proxy is blind: the worst ghost of a Fig. 7 placement sits where no focus or
// probe is (often at the edge of the active area next to an exciter, whose
// own near field spills over). So the proxy only proposes; the verdict
// decides:
//  1. the model's choice and the regular pattern are judged by the verdict of
//     their own drives: the transfer matrix of their exciters, the drives by
//     the scene's method (time reversal or the inverse filter), their level and
//     the whole-area verification, exactly as the table would be made;
//  2. the ghosts of the last placement judged (every focus whose largest |w|
//     beyond lambda/2 reaches 80 % of the threshold: where it does) become
//     probe rows of the model, one reciprocity simulation each, judged against
//     the foci farther than lambda/2 from them; the model then sees those
//     ghosts exactly (for time reversal the proxy at a probe row is the field
//     there), and the search runs again from the best placement so far;
//  3. repeated for the scene's verdict_rounds, or until a placement passes at
//     every focus, or the search proposes a placement already judged.
// Placements are ranked by the foci passing at the scene's amplitude, then
// the foci passing, then the worst whole-area contrast (verdict_better). The transfer simulations are shared: a site already simulated for
// one placement serves every later one.
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/result.h"
#include "pipeline/data/transfer_matrix.h"
#include "pipeline/data/verdict.h"
#include "pipeline/placement_search.h"

namespace calib::pipeline {

// What the search may add at most, for the cost model (model/cost_model.h):
// ghosts_per_round probes a round, within model_budget_bytes of contrast
// model; the placements judged are the model's choice, the regular pattern
// and one a round, each with at most `count` new transfer simulations.
constexpr std::size_t ghosts_per_round = 8;
constexpr double model_budget_bytes = 512.0 * 1024 * 1024;

// Whether calibrate() searches by the verdict: a searched placement (random,
// contrast criterion), a scene whose plate is time-invariant (H holds), and
// verdict_rounds not asking for the model's choice alone.
bool judged_by_verdict(const CalibrationInput &in, const PlacementSearch &search);

// Whether verification a ranks above b: more foci passing at the scene's
// amplitude (the verdict, with the focal peak at the target `amplitude_m`:
// a placement whose exciters cannot reach the target plays its foci at full
// scale, lower, and its ghosts with them, which is not what the scene asked
// for), then more foci passing, then a larger worst whole-area contrast.
bool verdict_better(const Verification &a, const Verification &b, double amplitude_m);
// The foci that pass with their peak within 1 % of amplitude_m.
std::size_t passing_at_target(const Verification &v, double amplitude_m);
// The figures a placement is ranked by (data/result.h PlacementReport::Judged,
// no sites, no proxy).
PlacementReport::Judged judged_figures(const Verification &v, double amplitude_m);

// Runs the search above from the model's choice in res.placement; leaves in
// res the best placement's exciters, signals, levels and verification (as
// signals_and_verification's judge_only pass makes them), the judged
// placements in res.placement, and returns that placement's H.
TransferMatrix search_by_verdict(const CalibrationInput &in, PlacementSearch &search, const ProgressFn &progress,
                                 CalibrationResult &res);

// The exciters calibrate() would place for the scene (stages 1-2 and, where
// it applies, the search by the verdict), without the table's later stages.
std::vector<Point> placed_exciters(const CalibrationInput &in, const ProgressFn &progress = {});

} // namespace calib::pipeline
