// A focus's drive as the table stores it: one signal per exciter at the
// device rate, its shape at full scale, its level and the quantized samples.
// What either method designs (design/), the verification plays and the table
// writer stores.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct DriveSignals {
    unsigned channels = 0;
    size_t frames = 0;
    double rate_hz = 0;
    std::vector<double> normalized; // [frame][channel], peak |value| = 1 (before dither)
    double level = 1.0;             // playback level: samples = level * normalized * 32767 + dither
    std::vector<int16_t> samples;   // [frame][channel]
    // counts = gain * (reversed, resampled recording): a drive of s counts at an
    // exciter is s / gain of the recorded quantity (m per N of pulse force).
    double gain = 0;
    // Seconds from the start of playback to the focus instant (the centre of
    // the refocused pulse): (kept samples - 1) / sim rate - pulse_duration / 2.
    double focus_delay_s = 0;
};

// The quantized samples of every drive, in order: what a table stores.
inline std::vector<std::vector<int16_t>> stored_samples(const std::vector<DriveSignals> &drives)
{
    std::vector<std::vector<int16_t>> s;
    s.reserve(drives.size());
    for (const DriveSignals &d : drives)
        s.push_back(d.samples);
    return s;
}

} // namespace calib::pipeline
