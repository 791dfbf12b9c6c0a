// The plate's transfer matrix H: once the exciters are placed, one forward
// simulation per exciter with a band-limited unit force, recording the
// displacement on an observation lattice over the whole plate and at chosen
// points (the foci) exactly, stored decimated in time. For a linear,
// time-invariant plate (loss, the thick plate; the exciter model acts on the
// drive before H) every playback is a convolution of the drive with H, and by
// reciprocity the response exciter -> focus is the focus -> exciter response
// time reversal needs. Its cost and memory do not grow with the foci.
//
// Lattice spacing: a stride of the plate grid with stride h <= lambda_min / 4,
// lambda_min the A0 wavelength at the pulse's highest significant frequency
// (pulse_max_frequency_hz): four points per shortest wavelength, twice the
// spatial Nyquist rate, so the field between lattice points is recovered by a
// cubic interpolation to a few per cent and no spatial peak hides between them.
//
// Time decimation without an anti-alias filter: the force is a Kaiser-windowed
// sinc (80 dB stop band) whose stop band starts at half the stored rate; a
// linear time-invariant plate adds no frequency, so the displacement has no
// content above half the stored rate but the force's -80 dB leakage, and
// picking every M-th step is alias-free to that level. The sinc is centred
// (its delay is taken off when recording), so H is the zero-phase band-limited
// impulse response: H[s] is the displacement at time s M k after a 1 N s
// impulse at time 0, per N s.
#pragma once
#include "pipeline/data/input.h"
#include "pipeline/data/transfer_matrix.h"

#include "engine/lanes.h"

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

namespace calib::pipeline {

struct TransferOptions {
    std::size_t decimation = 1; // M: record every M-th step
    std::size_t samples = 0;    // stored samples per response
    int lattice_stride = 0;     // 0: no lattice, only the exact points
    // Band edges of the force (Hz): flat (to 1e-4) below pass_hz, -80 dB above
    // stop_hz. stop_hz <= 0: the force is one 1 N s impulse in the first step
    // (the scheme's own impulse response, for tests at decimation 1).
    double pass_hz = 0, stop_hz = 0;
};

// The sizes calibrate() uses for a scene: rate >= search_rate (integer
// decimation of the scene's time step), the kept window plus the verification
// tail, the lattice stride for lambda_min / 4.
TransferOptions transfer_options(const CalibrationInput &in, double time_step_s);
// Lattice of a stride on the scene's grid.
ObservationLattice observation_lattice(const CalibrationInput &in, int stride);

// The centred Kaiser-windowed sinc at the simulation rate (N per step), unit
// impulse (sum * k = 1 N s), and its centre index.
std::vector<double> band_limited_impulse(double time_step_s, double pass_hz, double stop_hz, std::size_t &centre);

// The force of an impulse simulation: the band-limited impulse above when
// stop_hz > 0, else one 1 N s impulse in the first step (centre 0).
std::vector<double> impulse_force(double time_step_s, double pass_hz, double stop_hz, std::size_t &centre);

// One impulse simulation per source side by side in the engine's lanes
// (engine/lanes.h; the caller checks lanes_apply): the receivers and, with
// lattice_stride > 0, the lattice read after the impulse's centre step and
// every `interval` steps after it, `samples` times. `options`: one
// simulation's; the batches share the OpenMP team. Throws engine::SourceFailure.
std::vector<engine::LaneRecord> impulse_lanes(std::shared_ptr<const engine::PlateOperator> plate,
                                              const engine::SimulationOptions &options,
                                              const std::vector<Point> &sources, const std::vector<Point> &receivers,
                                              int lattice_stride, double pass_hz, double stop_hz, std::size_t interval,
                                              std::size_t samples,
                                              const std::function<void(std::size_t, std::size_t)> &progress);

// One simulation per exciter (in parallel, one core each; side by side in
// lanes where the plate allows), recording the lattice and `exact_points`.
// Throws std::runtime_error on divergence.
using TransferProgress = std::function<void(std::size_t done, std::size_t total)>;
TransferMatrix simulate_transfer(const CalibrationInput &in, const std::vector<Point> &exciters,
                                 const std::vector<Point> &exact_points, const TransferOptions &options,
                                 const TransferProgress &progress = {});

// The scene's exciters' force gains ([exciters] force_gains) on H: response c
// times gain c, for an H whose channels are the scene's exciters in order.
// The one place the gains act on H (transfer_for and perturbed_transfer call it).
void apply_force_gains(const CalibrationInput &in, TransferMatrix &H);

// H for verifying these exciters: the scene's lattice and the foci exactly,
// with the scene's force gains.
TransferMatrix transfer_for(const CalibrationInput &in, const std::vector<Point> &exciters,
                            const ProgressFn &progress = {});

} // namespace calib::pipeline
