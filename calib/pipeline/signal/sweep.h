// The bench's excitation (docs/bench.md, "The plan and measurements.toml"):
// Farina's exponential sine sweep (A. Farina, "Simultaneous measurement of
// impulse response and distortion with a swept-sine technique", AES 108th
// Convention, 2000) and the plan that plays it on each exciter in turn.
//
//   x(t) = A w(t) sin(phi(t)),  phi(t) = 2 pi f1 L (exp(t / L) - 1),  L = T / ln(f2 / f1)
//
// so the instantaneous frequency phi'(t) / 2 pi = f1 exp(t / L) runs from f1
// at t = 0 to f2 at t = T exponentially (equal time per octave); w is 1 but
// for raised-cosine fades over the first and last fraction of an octave.
// Deconvolved, the k-th harmonic distortion product of the system lands
// L ln(k) before the linear response (harmonic_lead_s), which is how the
// deconvolution (deconvolve.h) drops it. Pure functions, nothing of a scene.
#pragma once
#include <cstddef>
#include <cstdint>
#include <vector>

namespace calib::pipeline {

struct SweepSpec {
    double f1_hz = 0, f2_hz = 0; // 0 < f1 < f2 < rate / 2
    double duration_s = 0;       // T
    double rate_hz = 0;
    double amplitude = 1; // A, of full scale
    // The raised-cosine fades: over the time the sweep takes to rise this many
    // octaves from f1, and to rise this many octaves to f2.
    double fade_in_octaves = 1.0 / 3;
    double fade_out_octaves = 1.0 / 6;
};

// Throws std::invalid_argument naming what is wrong (a band outside (0, rate / 2),
// no duration, fades longer than the sweep, an amplitude outside (0, 1]).
void check_sweep(const SweepSpec &s);
// L = T / ln(f2 / f1) (s).
double sweep_rate_constant_s(const SweepSpec &s);
// phi(t) (rad) and phi'(t) / 2 pi (Hz), for any t (no fades).
double sweep_phase(const SweepSpec &s, double t_s);
double sweep_frequency_hz(const SweepSpec &s, double t_s);
// Samples at t = i / rate, i < sweep_frames(s) = round(T rate): A w(t) sin(phi(t)).
std::size_t sweep_frames(const SweepSpec &s);
std::vector<double> exponential_sweep(const SweepSpec &s);
// Where the k-th harmonic's response lands before the linear one: L ln(k) (s).
double harmonic_lead_s(const SweepSpec &s, int k);

// The deconvolved SNR of a sweep against a recording SNR (both dB, power):
// deconvolution gathers the sweep's energy, spread over T seconds and a band
// of B Hz, into the impulse response: SNR_ir ~= SNR_rec + 10 log10(T B).
double deconvolved_snr_db(double recording_snr_db, double sweep_s, double bandwidth_hz);
// The sweep length that reaches `deconvolved_snr_db` (the inverse of the above).
double sweep_s_for_snr(double deconvolved_snr_db, double recording_snr_db, double bandwidth_hz);

// The plan: `channels` channels, channel c silent but for the sweep from
// start_frames[c] = lead + c (sweep + gap); each sweep is followed by `gap`
// frames of silence (the plate's decay) before the next one starts.
struct PlanLayout {
    std::size_t channels = 0, lead_frames = 0, sweep_frames = 0, gap_frames = 0;
    std::vector<std::size_t> start_frames;
    std::size_t total_frames = 0; // lead + channels (sweep + gap)
};
PlanLayout plan_layout(std::size_t channels, std::size_t lead_frames, std::size_t sweep_frames, std::size_t gap_frames);

// PCM_16 counts of full-scale-normalised samples: round(32768 x), clamped to
// [-32768, 32767]; a PCM reader (libsndfile's) gives back count / 32768.
std::vector<int16_t> quantize_pcm16(const std::vector<double> &x);
// The plan's samples, interleaved (frame-major: [frame][channel]); `sweep`
// must hold layout.sweep_frames samples.
std::vector<int16_t> plan_samples(const PlanLayout &layout, const std::vector<int16_t> &sweep);

} // namespace calib::pipeline
