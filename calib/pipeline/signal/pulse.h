// The haptic pulse emitted at a focus during calibration (and expected back
// there after time reversal).
#pragma once
#include <string>
#include <vector>

namespace calib::pipeline {

enum class PulseShape {
    hann_burst,     // sin(2 pi f t) under a Hann window of `cycles` periods (the seed's pulse)
    gaussian_burst, // sin(2 pi f t) under a Gaussian, -40 dB at the same total length
    ricker,         // Mexican-hat wavelet with peak spectral frequency f (cycles ignored)
};

struct PulseSpec {
    PulseShape shape = PulseShape::hann_burst;
    double centre_hz = 300.0;
    double cycles = 2.0;
    double amplitude_m = 10e-6; // target focal displacement (the seed's +-10 um)
};

// "hann_burst", ... -> shape; throws std::invalid_argument listing the known names.
PulseShape parse_pulse_shape(const std::string &name);

// Support [0, duration) outside which the pulse is zero (or below -40 dB for Gaussian shapes).
double pulse_duration_s(const PulseSpec &p);
// Unit-peak-order waveform value at time t (s), zero outside the support.
double pulse_value(const PulseSpec &p, double t_s);
std::vector<double> sample_pulse(const PulseSpec &p, double rate_hz);
// Highest frequency where the amplitude spectrum is at least `level` (relative
// to its maximum): the band the simulation grid must resolve. Computed from
// the sampled waveform, not from a formula, so every shape is handled alike.
double pulse_max_frequency_hz(const PulseSpec &p, double level = 0.01);

// Rate of the stored recordings for a pulse: 4x its highest significant
// frequency keeps the band with margin for soxr's transition band;
// everything after the simulation (search, time reversal) works at this rate.
double search_rate(const PulseSpec &p);

} // namespace calib::pipeline
