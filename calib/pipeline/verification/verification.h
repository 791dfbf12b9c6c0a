// Verification through the transfer matrix: a drive's field at the foci and
// on the observation lattice is its convolution with H (transfer/playback.h), and the
// per-focus figures (data/verdict.h FocusMetrics) are read from it: the focal
// peak and its time, the other foci, the field at the focus instant (spot,
// contrast there) and at all times over the active area (whole-area contrast,
// perceived position, the area above the threshold).
//
// The forward path (verification_forward.cpp) serves scenes whose plate is
// not time-invariant ([effects.finger]); it measures the foci and the field at
// the focus instant on the plate grid, not the whole area at all times.
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/transfer/playback.h" // drive_forces
#include "pipeline/data/transfer_matrix.h"
#include "pipeline/data/verdict.h"

#include <cstdint>
#include <vector>

namespace calib::pipeline {

// Drive the exciters with per-focus signals ([n][c] int16 at rate_hz, full
// scale = force_full_scale_n) and measure every focus: by convolution with the
// transfer matrix of these exciters (simulated here, one simulation per
// exciter), or, with [effects.finger], by a forward simulation per focus.
// Without `whole_area` only the foci are measured (traces, peaks, contrast
// over the other foci).
Verification verify_signals(const CalibrationInput &in, const std::vector<Point> &exciters,
                            const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                            const ProgressFn &progress = {}, bool whole_area = true);

// One multichannel drive (e.g. what the device played, or a superposition of
// foci): returns traces[0][g] and, per focus, the peak and its time; by
// convolution with H (or forward simulation with [effects.finger]).
Verification verify_drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                          const std::vector<float> &frames, unsigned channels, double rate_hz,
                          const ProgressFn &progress = {});

// Focal peak (m) of each focus's signals, foci only (the level pass).
std::vector<double> focal_peaks(const CalibrationInput &in, const TransferMatrix &H,
                                const std::vector<std::vector<int16_t>> &signals, double rate_hz);

Verification verify_signals_with(const CalibrationInput &in, const TransferMatrix &H,
                                 const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                 const ProgressFn &progress = {}, bool whole_area = true);
Verification verify_drive_with(const CalibrationInput &in, const TransferMatrix &H, const std::vector<float> &frames,
                               unsigned channels, double rate_hz);

// The forward path (one simulation per focus, the finger composed).
Verification verify_signals_forward(const CalibrationInput &in, const std::vector<Point> &exciters,
                                    const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                    const ProgressFn &progress, bool snapshots);
Verification verify_drive_forward(const CalibrationInput &in, const std::vector<Point> &exciters,
                                  const std::vector<float> &frames, unsigned channels, double rate_hz,
                                  const ProgressFn &progress);

// Diameter of the circle with the area of the connected region around the
// focus where |w| >= level, on a (nx + 1) x (ny + 1) grid of spacing h.
double spot_diameter(const std::vector<float> &field, int nx, int ny, double h, Point focus, double level);

// Whether focus g counts as another focus of focus f in the other-foci
// criterion: farther than lambda/2 from it. On a grid finer than the focal
// spot the neighbours inside the spot cross the threshold by construction;
// on the seed's 3 x 3 grid (167 mm apart, lambda/2 = 81 mm) every focus counts.
bool is_other_focus(const CalibrationInput &in, std::size_t f, std::size_t g, double lambda_half_m);

// int16 samples as floats at full scale 1.0.
std::vector<float> to_unit(const std::vector<int16_t> &s);

} // namespace calib::pipeline
