// Peaks of band-limited sampled signals. A 300 Hz wave sampled at 2.9 kHz
// shows its peak up to 5 % low at the samples (1 - cos(pi f / rate)); the
// verification reads H at that rate, so every peak it reports is refined
// between samples by Kaiser-windowed sinc interpolation (half-width 8
// samples, on a 1/16-sample lattice, then a parabola through the best three),
// which recovers a band-limited signal's peak to 1e-4 for content below a
// quarter of the rate.
#pragma once
#include <cstddef>
#include <vector>

namespace calib::pipeline {

struct Peak {
    double value = 0; // |x| at the peak
    double index = 0; // fractional sample index
};

// Value at fractional index t (zero outside the signal).
double interpolate(const float *x, std::size_t n, double t);
// Largest |x|: every local maximum within 20 % of the largest sample is refined.
Peak refined_peak(const float *x, std::size_t n);
inline Peak refined_peak(const std::vector<float> &x) { return refined_peak(x.data(), x.size()); }
// Largest sample |x| (no refinement).
double sample_peak(const float *x, std::size_t n);

} // namespace calib::pipeline
