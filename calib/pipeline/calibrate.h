// The calibration pipeline, in stages: responses (one reciprocity simulation
// per focus of the placement subset), placement search (placement_search.h,
// judged by the verdict: placement_verdict.h), the transfer matrix H of the
// placed exciters (transfer/), drive signals from H (design/), level and
// verification by convolution with H (verification/), the radiated sound and
// the tolerance box (calibrate_stages.h, robustness/). A scene with
// [effects.finger] verifies by forward simulation per focus instead: the
// finger changes the plate at each touch position, so H does not hold.
// `calibgen calibrate` and `calibgen verify` are thin shells around this and
// the table writer (table_writer.h).
// The floors of pipeline/ under it: calib/CMakeLists.txt.
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/result.h"

namespace calib::pipeline {

// Refuses impossible scenes before any simulation (std::invalid_argument,
// one line naming the scene key): foci off the plate, no room for the
// exciters, a window shorter than one crossing of the plate.
void check_feasible(const CalibrationInput &in);

CalibrationResult calibrate(const CalibrationInput &in, const ProgressFn &progress = {});

} // namespace calib::pipeline
