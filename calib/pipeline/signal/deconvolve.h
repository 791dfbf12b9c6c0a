// The impulse response of a recorded sweep (docs/bench.md): the recording of
// one exciter's segment of the plan divided, in frequency, by the samples the
// exciter played.
//
//   H(f) = W(f) R(f) conj(X(f)) / (|X(f)|^2 + eps),  eps = 1e-6 max_{f_lo <= f <= f_hi} |X(f)|^2
//
// on a transform of at least n + m samples (a linear, not circular, division:
// the response at negative times, where an exponential sweep's harmonic
// distortion products land (sweep.h, harmonic_lead_s), stays apart from the
// response after t = 0 and is dropped with it). eps only bounds the gain where
// the excitation has next to no energy (its fades, its quantisation floor
// outside the band): inside the band |X|^2 stays within a factor f2 / f1 of
// its maximum, so the bias is below 1e-6 f2 / f1 (about -90 dB). W is the
// band taper: 0 outside (f_lo, f_hi), 1 inside but for raised-cosine ramps in
// log frequency over the band's first and last third of an octave (a quarter
// of the band's octaves for a band narrower than 4/3 octave). W is zero-phase;
// its ringing around t = 0 (about 1 / the ramp's width in Hz) is cut with the
// negative times, so give a band a third of an octave wider on each side than
// the one the response is read in (the sweep's own band is).
#pragma once
#include <cstddef>
#include <vector>

namespace calib::pipeline {

// The discrete impulse response h (recorded units per unit of normalised
// drive, per sample: recording = excitation * h) over its first ir_length
// samples, band-limited to [f_lo, f_hi] (Hz, at `rate` Hz). `recording` is the
// segment that starts where the excitation starts (n samples: the excitation's
// and the response's decay); `excitation` the m samples exactly as played.
// Throws std::invalid_argument for empty inputs, ir_length > n, a band outside
// (0, rate / 2], or an excitation without energy in the band.
std::vector<double> impulse_response(const double *recording, std::size_t n, const double *excitation, std::size_t m,
                                     std::size_t ir_length, double f_lo, double f_hi, double rate);

// W(f) above (exposed for the tests and for a caller that filters alike).
double deconvolution_taper(double f_hz, double f_lo, double f_hi);
// The transform size impulse_response uses for n + m samples: the smallest
// 2^a 3^b 5^c at least as large.
std::size_t deconvolution_fft_size(std::size_t samples);

} // namespace calib::pipeline
