// Stages 1 and 2 of a calibration: the responses of the placement's emitters
// (one reciprocity simulation each: the pulse emitted at a focus of the
// placement subset, or a probe point, recorded at every candidate exciter
// site at once) and the placement search over them (placement/placement.h).
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/result.h"
#include "pipeline/plan.h"

#include <cstddef>
#include <memory>
#include <vector>

namespace calib::pipeline {

// Stages 1-2, kept open for the search by the verdict (placement_verdict.h):
// the emitters' responses at every candidate site and the contrast model
// over them (placement/placement.h), to which probe points can be added (one
// reciprocity simulation each) before searching again.
class PlacementSearch {
  public:
    // Simulates the plan's emitters and searches: fills res.placement,
    // res.exciters, res.search_rate_hz and the simulation and search times.
    PlacementSearch(const CalibrationInput &in, const CalibrationPlan &plan, const ProgressFn &progress,
                    CalibrationResult &res);
    ~PlacementSearch();
    // A random placement under the contrast criterion: refine() applies.
    bool refinable() const { return refinable_; }
    // Adds the probe points as rows where the field must stay small (each
    // counting against the foci farther than lambda/2 from it) and searches
    // again, the first restart from `start`; the new placement (site indices).
    std::vector<std::size_t> refine(const std::vector<Point> &probes, const std::vector<std::size_t> &start,
                                    const ProgressFn &progress);
    std::vector<Point> points(const std::vector<std::size_t> &chosen) const;
    std::size_t probes() const;
    // How many more probe rows fit the contrast model in `bytes` in all.
    std::size_t room(double bytes) const;
    // The foci of the subset, then the probe points (the plan's, then those added).
    const std::vector<Point> &emitters() const;
    // The contrast model's worst focus (dB) for a placement: the first model's
    // (the plan's emitters only), the proxy the verdict is compared with.
    double proxy_db(const std::vector<std::size_t> &chosen) const;

  private:
    struct State;
    const CalibrationInput &in_;
    std::vector<Point> sites_;
    double rate_d_ = 0, lambda_half_m_ = 0;
    bool refinable_ = false;
    std::unique_ptr<State> state_;
};

} // namespace calib::pipeline
