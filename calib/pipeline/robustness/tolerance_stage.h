// The tolerance stage, the other stage calibrate() adds for a scene with
// [tolerance] or a robust design (docs/robustness.md; robust_design.h): the
// table (and, with a robust design, the plain design beside it) verified on
// every plate of the box, the worst case of each figure next to the nominal
// ones.
#pragma once
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/input.h"
#include "pipeline/data/result.h"
#include "pipeline/data/tolerance_spec.h"
#include "pipeline/data/transfer_matrix.h"
#include "pipeline/robustness/robust_design.h"

#include <cstdint>
#include <vector>

namespace calib::pipeline {

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

} // namespace calib::pipeline
