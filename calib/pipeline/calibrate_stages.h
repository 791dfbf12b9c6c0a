// The stages calibrate() runs on the transfer matrix H (calibrate.cpp): the
// drives by the scene's method, their level and verification, then the
// radiated sound and the tolerance box.
#pragma once
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/input.h"
#include "pipeline/data/result.h"
#include "pipeline/data/transfer_matrix.h"

#include <vector>

namespace calib::pipeline {

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

} // namespace calib::pipeline
