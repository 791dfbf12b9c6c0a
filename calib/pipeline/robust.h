// The two stages calibrate() adds for a scene with [tolerance] or a robust
// design (docs/robustness.md).
//
// Robust design ([calibration] robust = { loss = [...], E_scale = [...] }),
// by the scene's method over the nominal plate and the member plates.
//
// The inverse filter: stacked least squares (inverse_filter.h), one drive
// per focus minimising the sum over the plates of the inverse filter's
// objective (the focus and the whole active area at all times), each member
// simulated with the observation lattice; the regularisation relative to the
// largest eigenvalue of the summed normal matrix.
//
// Time reversal: from the ensemble average of the exciter -> focus responses
// of the nominal plate and of each member plate (one parameter changed per
// member). Averaging keeps what the plates share, the early, direct paths,
// and lets the late reverberation, whose phase a few per cent of wave speed
// or loss scrambles, cancel: the matched filter of the expected response
// instead of one plate's. An ensemble of the nominal plate alone is the plain
// design, sample for sample.
//
// Tolerance stage: the table (and, with a robust design, the plain design
// beside it) verified on every plate of the box, the worst case of each
// figure next to the nominal ones.
#pragma once
#include "pipeline/calibrate.h"
#include "pipeline/tolerance.h"

#include <string>
#include <vector>

namespace calib::pipeline {

// The member plates besides the nominal one: each listed loss factor (at the
// pulse centre) and each E scaling; a value equal to the nominal one is the
// nominal member.
std::vector<Perturbation> ensemble_members(const CalibrationInput &in, const RobustSpec &r);

// H at the foci only (no lattice), averaged over the nominal plate (`H`'s
// foci rows) and the members, each simulated with the nominal exciters.
TransferMatrix ensemble_transfer(const CalibrationInput &in, const TransferMatrix &H,
                                 const std::vector<Perturbation> &members, const ProgressFn &progress = {});

struct RobustDesign {
    std::vector<DriveSignals> signals;   // at full scale, like signals_from_transfer
    std::vector<Perturbation> members;   // without the nominal plate
    // With level = "margin": the focal amplitude to store per focus on the
    // nominal plate (instead of the scene's amplitude_m); empty otherwise.
    std::vector<double> amplitude_m;
    double seconds = 0;
};
RobustDesign robust_design(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress = {});

// Levels signals as calibrate() does (the scene's amplitude at each focus on
// the nominal plate, never above full scale) and returns them quantized.
std::vector<std::vector<int16_t>> level_as_stored(const CalibrationInput &in, const TransferMatrix &H,
                                                  std::vector<DriveSignals> signals);

// The table of `res` over the box (in.tolerance; without it, over the robust
// ensemble's members). `plain`: the plain design at full scale when the table
// is a robust one (empty otherwise).
ToleranceReport tolerance_stage(const CalibrationInput &in, const TransferMatrix &H, const CalibrationResult &res,
                                 std::vector<DriveSignals> plain, const RobustDesign *robust,
                                 const ProgressFn &progress = {});

}  // namespace calib::pipeline
