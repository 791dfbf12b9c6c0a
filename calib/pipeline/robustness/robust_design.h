// Robust design ([calibration] robust = { loss = [...], E_scale = [...] }),
// one of the two stages calibrate() adds for a scene with [tolerance] or a
// robust design (docs/robustness.md; the other: tolerance_stage.h), by the
// scene's method over the nominal plate and the member plates.
//
// The inverse filter: stacked least squares (design/inverse_filter.h), one
// drive per focus minimising the sum over the plates of the inverse filter's
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
#pragma once
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/input.h"
#include "pipeline/data/tolerance_spec.h"
#include "pipeline/data/transfer_matrix.h"

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
    std::vector<DriveSignals> signals; // at full scale, like signals_from_transfer
    std::vector<Perturbation> members; // without the nominal plate
    // With level = "margin": the focal amplitude to store per focus on the
    // nominal plate (instead of the scene's amplitude_m); empty otherwise.
    std::vector<double> amplitude_m;
    double seconds = 0;
};
RobustDesign robust_design(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress = {});

} // namespace calib::pipeline
