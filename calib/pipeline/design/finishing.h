// What happens to a drive after its design, by either method (time reversal,
// the inverse filter): raised-cosine fades at both ends (no click), the
// device rate, normalisation to full scale, the level and seeded dither, and
// the pre-compensation for the scene's exciter.
#pragma once
#include "engine/effects/exciter.h"
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/input.h"

#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct TimeReversalOptions {
    double truncate_fraction = 0.3; // of the recording window (the seed's 30 %; time reversal only)
    double output_rate_hz = 48000.0;
    double taper_s = 0.002; // raised-cosine fade at both ends (no click)
    bool dither = true;     // TPDF, +-1 LSB, seeded (reproducible)
    uint64_t dither_seed = 1;
};

// The seed of a drive's dither: the scene's [exciters] seed and the drive's
// index (the focus, in scene order; a drive of no single focus takes an
// index no focus has). Each drive has its own stream, so the signals do not
// depend on the thread count.
inline uint64_t dither_seed(const CalibrationInput &in, uint64_t drive) { return in.exciters.seed * 1000003u + drive; }

// The scene's options for drive `drive` (dither_seed): its kept fraction,
// device rate and dither.
TimeReversalOptions drive_options(const CalibrationInput &in, uint64_t drive);

// drive[c][n] at sim_rate_hz in playback order; raised-cosine fades of
// taper_s at both ends (no click), resampled to the device rate, normalized
// to full scale and quantized. focus_delay_s is stored as given.
DriveSignals finish_drive_signals(std::vector<std::vector<double>> drive, double sim_rate_hz, double focus_delay_s,
                                  const TimeReversalOptions &options);

// Re-quantize at `level` x full scale (0 < level <= 1): the signals keep their
// shape, their peak becomes level * 32767 counts (seeded TPDF dither as above).
void requantize(DriveSignals &d, double level, const TimeReversalOptions &options);

// Pre-compensates a drive at full scale by the regularised inverse of the
// exciter ([effects] exciter with precompensate, engine/effects/exciter.h),
// as calibrate() does to every table's drives.
void precompensate_for_exciter(DriveSignals &d, const engine::effects::ExciterSpec &e, const TimeReversalOptions &tro);

} // namespace calib::pipeline
