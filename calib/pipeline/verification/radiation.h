// What a listener hears, first estimate: the sound pressure the plate
// radiates, from its simulated normal acceleration, by the baffled-plate
// Rayleigh integral (the plate set in an infinite rigid wall):
//   p(r, t) = rho0 / (2 pi) sum_n a_n(t - R_n / c0) / R_n  dA,
// over the observation lattice of H (a_n the second time derivative of the
// displacement, taken in the frequency domain, R_n the distance from lattice
// point n to the listener, dA the lattice cell). The listener is on the axis
// through the plate centre. The level is A-weighted (IEC 61672-1) and given as
// the sound exposure level L_AE (re 20 uPa^2 s, the energy of the whole
// playback and its decay) and L_Aeq over the drive.
//
// Limits: H is band-limited to half its rate (about 1.4 kHz on Fig. 7), so
// nothing above it is in the estimate (the drive has nothing there either: it
// is designed at that rate; the 16-bit dither and the exciters' own
// radiation are not modelled); below the coincidence frequency a baffle
// overstates an unbaffled or framed panel's radiation at low frequencies (no
// acoustic short circuit round the edges); the air does not load the plate;
// no room.
#pragma once
#include "pipeline/data/transfer_matrix.h"

#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct CalibrationInput;

struct RadiatedSound {
    double exposure_level_dba = 0; // L_AE
    double laeq_dba = 0;           // L_Aeq over the drive's duration
    double peak_pa = 0;            // largest |p| (unweighted)
};

constexpr double air_density_kg_m3 = 1.204; // 20 C, sea level
constexpr double sound_speed_m_s = 343.2;

// A-weighting gain (linear, 1 at 1 kHz) at frequency f (IEC 61672-1).
double a_weighting(double f_hz);

// The Rayleigh integral over a lattice: w[n][s] the displacement (m) of
// lattice point n at time s / rate_hz; the pressure (Pa) at (x, y, z) at the
// same instants, on `samples` samples. The acceleration is taken by FFT; the
// field must start quiet, and its last 10 ms (at most an eighth) fade out.
std::vector<double> rayleigh_pressure(const ObservationLattice &lattice, const std::vector<std::vector<float>> &w,
                                      double rate_hz, Point listener, double z_m, std::size_t samples);

// A-weighted sound exposure (Pa^2 s) of a pressure signal.
double a_weighted_exposure(const std::vector<double> &p, double rate_hz);

// Every focus's stored signals ([n][c] int16 at rate_hz) played through H,
// heard on axis at distance_m above the plate centre. The pressure is linear
// in the drive, so the Rayleigh integral of each exciter's lattice responses is formed once
// (Q_c) and each focus costs one transform per channel. The end of the record
// fades in the pressure (10 ms, raised cosine), not in each point's
// displacement as rayleigh_pressure does: the two differ by the propagation
// delays across the plate within the fade (a few ms at most).
std::vector<RadiatedSound> radiated_sounds(const CalibrationInput &in, const TransferMatrix &H,
                                           const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                                           double distance_m = 0.5);

} // namespace calib::pipeline
