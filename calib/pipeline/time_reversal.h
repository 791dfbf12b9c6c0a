// Time-reversal drive signals for one focus: from the displacement recorded at
// each exciter site while the pulse is emitted at the focus (reciprocity),
// keep the first part of the window, reverse it, taper it, resample it to the
// device rate, normalize it to full scale and quantize it.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct TimeReversalOptions {
    double truncate_fraction = 0.3;   // of the recording window (the seed's 30 %)
    double output_rate_hz = 48000.0;
    double taper_s = 0.002;           // raised-cosine fade at both ends (no click)
    bool dither = true;               // TPDF, +-1 LSB, seeded (reproducible)
    uint64_t dither_seed = 1;
};

struct DriveSignals {
    unsigned channels = 0;
    size_t frames = 0;
    double rate_hz = 0;
    std::vector<double> normalized;   // [frame][channel], peak |value| = 1 (before dither)
    double level = 1.0;               // playback level: samples = level * normalized * 32767 + dither
    std::vector<int16_t> samples;     // [frame][channel]
    // counts = gain * (reversed, resampled recording): a drive of s counts at an
    // exciter is s / gain of the recorded quantity (m per N of pulse force).
    double gain = 0;
    // Seconds from the start of playback to the focus instant (the centre of
    // the refocused pulse): (kept samples - 1) / sim rate - pulse_duration / 2.
    double focus_delay_s = 0;
};

// recordings[c][n] at sim_rate_hz. Throws std::invalid_argument with a
// one-line reason on empty, non-finite or all-zero input (a focus the
// exciters cannot reach must never become a NaN gain).
DriveSignals make_drive_signals(const std::vector<std::vector<double>> &recordings, double sim_rate_hz,
                                double pulse_duration_s, const TimeReversalOptions &options);

// The steps after the design of a drive (either method): drive[c][n] at
// sim_rate_hz in playback order; raised-cosine fades of taper_s at both ends
// (no click), resampled to the device rate, normalized to full scale and
// quantized. focus_delay_s is stored as given.
DriveSignals finish_drive_signals(std::vector<std::vector<double>> drive, double sim_rate_hz, double focus_delay_s,
                                  const TimeReversalOptions &options);

// Re-quantize at `level` x full scale (0 < level <= 1): the signals keep their
// shape, their peak becomes level * 32767 counts (seeded TPDF dither as above).
void requantize(DriveSignals &d, double level, const TimeReversalOptions &options);

// Band-limited resampling of one signal with soxr (high quality, linear phase).
std::vector<double> resample(const std::vector<double> &x, double in_rate_hz, double out_rate_hz);
// The same for signals of one length, through one filter design: each output
// equals resample() of its input.
std::vector<std::vector<double>> resample_all(const std::vector<std::vector<double>> &x, double in_rate_hz,
                                              double out_rate_hz);

}  // namespace calib::pipeline
