// The lead time: from the start of playback to the focal peak, the part of
// the touch-to-pulse latency the drive itself sets (docs/physics.md,
// Latency: the lead time dominates; 57 ms on the seed's Fig. 7).
// `[calibration] lead_time_s` asks for it; without it the drives keep the
// time-reversal window the scene's truncate_fraction x window_s gives, and
// the inverse filter aims at the same instant. Both methods place the pulse so that its largest |value| comes at
// the lead time:
//   time reversal: the kept window ends half a pulse after the focus instant
//     (design/time_reversal.h), so it is cut at lead - peak offset + duration / 2;
//   inverse filter: the target pulse is centred at lead - peak offset and the
//     drive ends at the lead time (causal, no longer than it).
// The peak offset is how far the pulse's largest |value| lies from its centre
// (a quarter period for a 2-cycle Hann burst at its centre frequency, less
// the envelope's pull; zero for a Ricker wavelet).
#pragma once
#include "pipeline/data/geometry.h"
#include "pipeline/data/input.h"

#include <vector>

namespace calib::pipeline {

// |t_peak - duration / 2| of the sampled pulse's largest |value| (s).
double pulse_peak_offset_s(const PulseSpec &p, double rate_hz);
// The lead time the drives aim at (s): lead_time_s, or where the kept
// time-reversal window puts the focal peak.
double target_lead_time_s(const CalibrationInput &in);
// Instant of the pulse centre at the focus (s): target lead - peak offset.
double focus_centre_s(const CalibrationInput &in);
// Length of the recording the time-reversal drive keeps (s), and its part of
// calibration.window_s (exactly truncate_fraction without lead_time_s).
double kept_window_s(const CalibrationInput &in);
double kept_fraction(const CalibrationInput &in);
// The plate crossing time the lead time cannot undercut: the farthest of
// `sites` (exciters or candidate sites) to the farthest focus, at the A0
// group velocity at the pulse centre (s).
double crossing_time_s(const CalibrationInput &in, const std::vector<Point> &sites);
// Refuses (std::invalid_argument, one line naming calibration.lead_time_s) a
// lead time shorter than the crossing of these sites or one whose kept
// window does not fit in calibration.window_s.
void check_lead_time(const CalibrationInput &in, const std::vector<Point> &sites);

} // namespace calib::pipeline
