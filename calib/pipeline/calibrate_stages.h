// The stages calibrate() runs in order (calibrate.cpp): responses and
// placement (calibrate_placement.cpp), the transfer matrix (transfer.h),
// signals from it, level and verification (verification.h).
#pragma once
#include "pipeline/calibrate.h"
#include "pipeline/plan.h"
#include "pipeline/transfer.h"

#include <memory>
#include <vector>

namespace calib::pipeline {

// Stages 1-2, kept open for the search by the verdict (placement_verdict.h):
// the emitters' responses at every candidate site and the contrast model
// over them (placement.h), to which probe points can be added (one
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

// Stages 4-5 on H: the drive signals of every focus by the scene's method
// (time reversal or the inverse filter), each focus's level for the target
// amplitude, the verification of the stored signals; fills res.signals,
// res.full_scale_peak_m, res.verification and their times.
// judge_only: the drives, their level and the verification, no more (no
// robust design, tolerance box or radiated sound): what the placement search
// judges a placement by.
void signals_and_verification(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                              CalibrationResult &res, bool judge_only = false);

// The stages after the verification (radiated sound, tolerance box), on the
// signals and verification in res; `plain` and `robust` as a robust design
// left them (empty and null otherwise).
struct RobustDesign;
void finish_stages(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                   CalibrationResult &res, std::vector<DriveSignals> plain = {}, const RobustDesign *robust = nullptr);

// Stage 4: the time-reversal signals of every focus from H (reciprocity:
// H's exciter -> focus response is the focus -> exciter recording), the
// pulse convolved in at H's rate, at full scale.
std::vector<DriveSignals> signals_from_transfer(const CalibrationInput &in, const TransferMatrix &H);

// Pre-compensates a drive at full scale by the regularised inverse of the
// exciter ([effects] exciter with precompensate, engine/effects/exciter.h),
// as calibrate() does to every table's drives.
void precompensate_for_exciter(DriveSignals &d, const engine::effects::ExciterSpec &e, const TimeReversalOptions &tro);

}  // namespace calib::pipeline
