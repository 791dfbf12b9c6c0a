// The stages calibrate() runs in order (calibrate.cpp): responses and
// placement (calibrate_placement.cpp), the transfer matrix (transfer.h),
// signals from it, level and verification (verification.h).
#pragma once
#include "pipeline/calibrate.h"
#include "pipeline/plan.h"
#include "pipeline/transfer.h"

#include <vector>

namespace calib::pipeline {

// Stages 1-2: fills res.placement, res.exciters, res.search_rate_hz and the
// simulation and search times.
void place_exciters(const CalibrationInput &in, const CalibrationPlan &plan, const ProgressFn &progress,
                    CalibrationResult &res);

// Stages 4-5 on H: the drive signals of every focus by the scene's method
// (time reversal or the inverse filter), each focus's level for the target
// amplitude, the verification of the stored signals; fills res.signals,
// res.full_scale_peak_m, res.verification and their times.
void signals_and_verification(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                              CalibrationResult &res);

// Stage 4: the time-reversal signals of every focus from H (reciprocity:
// H's exciter -> focus response is the focus -> exciter recording), the
// pulse convolved in at H's rate, at full scale.
std::vector<DriveSignals> signals_from_transfer(const CalibrationInput &in, const TransferMatrix &H);

// Pre-compensates a drive at full scale by the regularised inverse of the
// exciter ([effects] exciter with precompensate, engine/effects/exciter.h),
// as calibrate() does to every table's drives.
void precompensate_for_exciter(DriveSignals &d, const engine::effects::ExciterSpec &e, const TimeReversalOptions &tro);

}  // namespace calib::pipeline
