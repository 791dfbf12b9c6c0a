// The foci the exciter placement search works on. The search needs one
// reciprocity simulation per focus it weighs (the pulse emitted there,
// recorded at every candidate site) and a contrast model of
// sites x foci^2 x lags floats (placement.h), so it cannot take a dense grid
// whole (169 foci on the Fig. 7 panel: about 39 GB). It takes a bounded,
// representative subset instead; the signals of every focus still come from
// the transfer matrix H, and the verification measures every focus.
//
// The subset: all foci, in scene order, when they fit under the cap (so a
// 3 x 3 grid is searched exactly as before). Otherwise farthest-point
// sampling (Gonzalez 1985, the greedy k-centre): start at the focus nearest
// the centre of the foci's bounding box, then repeatedly add the focus
// farthest from every member so far; ties go to the lowest scene index, so
// the choice is deterministic. The members spread to the corners first, then
// the edges, then fill in; every focus lies within the covering radius r of a
// member, the members are pairwise at least r apart, and r is at most twice
// the best any subset of that size can do. It stops at the cap, or once r is
// down to half a wavelength (the focal spot).
#pragma once
#include "pipeline/data/geometry.h"

#include <cstddef>
#include <optional>
#include <vector>

namespace calib::pipeline {

struct FocusSubset {
    std::vector<std::size_t> members; // indices into the foci: scene order if all, else in the order chosen
    double covering_radius_m = 0;     // every focus lies within this distance of a member
};

// Farthest-point subset of at most `cap` foci (cap >= 1). When the foci do
// not all fit, it also stops once every focus lies within min_separation_m of
// a member, so no two members are that close: with lambda/2 (the focal spot)
// the search never weighs a focus against a neighbour inside its own spot.
FocusSubset farthest_point_subset(const std::vector<Point> &foci, std::size_t cap, double min_separation_m = 0);

// The largest distance from a focus to its nearest member.
double covering_radius(const std::vector<Point> &foci, const std::vector<std::size_t> &members);

// Default cap on the foci of the placement search: 9 (as many as the seed's
// 3 x 3 demonstrator: the corners, the edge middles and the centre of the
// active area), lowered where the contrast model (sites x K^2 x lags floats)
// would exceed max_contrast_model_bytes, but not below 4 (a search needs
// other foci to weigh a focus against). More is not better: the search
// maximizes the worst contrast over the foci it weighs, a proxy; on the dense
// Fig. 7 panel 9 weighed foci gave the best whole-area result of 9, 13 and 16
// at the least cost (docs/BENCHMARKS.md).
constexpr std::size_t default_placement_foci = 9, min_default_placement_foci = 4;
constexpr double max_contrast_model_bytes = 256.0 * 1024 * 1024;

// The cap for a scene: `asked` ([exciters] placement_foci) if given, else
// the default for `sites` candidate sites and `lags` lags of the contrast model.
std::size_t placement_focus_cap(std::optional<unsigned> asked, double sites, double lags);

// Lags of the contrast model for a recording window at the search rate
// (placement.h: the kept part of the window plus the window, less one).
double contrast_model_lags(double window_s, double truncate_fraction, double search_rate_hz);

} // namespace calib::pipeline
