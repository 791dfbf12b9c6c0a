// What a stored drive costs: its force energy, the part of it above the
// pulse's band (the audible part the haptic pulse does not need), and the
// focal peak it buys per unit of drive (the matched filter, time reversal,
// maximises this for a focus at a given instant: Cauchy-Schwarz).
#pragma once
#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct CalibrationInput;

struct DriveFigures {
    double energy_n2s = 0;           // sum over channels of the integral of F(t)^2 (N^2 s)
    double out_of_band_fraction = 0; // of that energy above the pulse's -40 dB band edge
    double peak_per_root_energy = 0; // focal peak / sqrt(energy) (m / (N s^0.5)); 0 without a peak
};

// The force energy alone: sum over channels of the integral of F(t)^2 (N^2 s)
// of stored int16 signals whose full scale is force_full_scale_n.
double drive_energy_n2s(const std::vector<int16_t> &samples, double force_full_scale_n, double rate_hz);

// One focus's stored signals ([n][c] int16 at rate_hz, full scale =
// force_full_scale_n) and its verified focal peak (m, at the stored level).
DriveFigures drive_figures(const CalibrationInput &in, const std::vector<int16_t> &samples, unsigned channels,
                           double rate_hz, double peak_m);

} // namespace calib::pipeline
