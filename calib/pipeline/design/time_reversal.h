// Time-reversal drive signals for one focus: from the displacement recorded at
// each exciter site while the pulse is emitted at the focus (reciprocity),
// keep the first part of the window, reverse it, and finish it as every drive
// is finished (finishing.h: fades, the device rate, full scale, quantization).
#pragma once
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/input.h"
#include "pipeline/data/transfer_matrix.h"
#include "pipeline/design/finishing.h"

#include <vector>

namespace calib::pipeline {

// recordings[c][n] at sim rate_hz. Throws std::invalid_argument with a
// one-line reason on empty, non-finite or all-zero input (a focus the
// exciters cannot reach must never become a NaN gain).
DriveSignals make_drive_signals(const std::vector<std::vector<double>> &recordings, double sim_rate_hz,
                                double pulse_duration_s, const TimeReversalOptions &options);

// Stage 4 of a calibration by time reversal: the drive signals of every focus
// from H (reciprocity: H's exciter -> focus response is the focus -> exciter
// recording), the pulse convolved in at H's rate, the kept window the scene's
// lead time asks for (data/lead_time.h), at full scale. With [calibration]
// exciter_gains = "minimax" (the default) and H's observation lattice, each
// exciter's recording is scaled by the gain that holds the field beyond
// lambda/2 in the active area lowest over the focus (exciter_gains.h), judged
// on the lattice at every time the verification plays.
// `progress` ("signals", foci done, foci) when the gains are judged.
// `judged_on`: the gains judged through this matrix instead of H (the same
// exciters, rate and foci, with the lattice H may lack: the robust design's
// average is designed on, the nominal plate judged).
std::vector<DriveSignals> signals_from_transfer(const CalibrationInput &in, const TransferMatrix &H,
                                                const ProgressFn &progress = {},
                                                const TransferMatrix *judged_on = nullptr);

} // namespace calib::pipeline
