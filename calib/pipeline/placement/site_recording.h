// The placement's reciprocity recordings: a unit force impulse at an emitter
// (a focus or a probe point), the displacement at every candidate exciter
// site, delivered at the search rate R (pipeline/plan.h).
//
// Recording every site at every step cost over 10x the plate update (a
// receiver read and a double appended per site and step, then soxr over the
// full-rate traces), so the simulation records at a rate of a few times the
// band instead:
// - the force is the band-limited impulse of transfer/transfer.h (a centred
//   Kaiser-windowed sinc, 80 dB stop band) flat to 1e-4 up to R / 2 and
//   stopped from half the recording rate 1 / (M k), M >= 2 the decimation;
// - a linear time-invariant plate adds no frequency, so every M-th step of the
//   field holds the band alias-free (to the force's -80 dB leakage): the
//   engine copies the whole field every M-th step (Simulation::record_lattice,
//   taken in chunks so memory stays a few frames), and the sites are read off
//   the copies with the receivers' own bilinear weights;
// - soxr then takes the short recordings from 1 / (M k) to R, as it took the
//   full-rate traces before. Below R / 2 the result equals the full-rate path
//   to the force's pass-band ripple (1e-4); above it soxr removes both.
// Sample n of a recording is the displacement at time (n + 1) k (the state
// after step n of the impulse's own response; the sinc's delay is taken off),
// per N s of impulse.
// A simulation too coarse for M >= 2 (1 / k < 4 R) records every step of the
// one-step impulse's response, as before.
#pragma once
#include "engine/simulation.h"
#include "pipeline/data/geometry.h"

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

namespace calib::pipeline {

// Field copies per chunk: the engine records one chunk while the caller reads
// the last (memory: twice this many copies of the field; each run() between
// two reads ends with a whole-field scan).
constexpr std::size_t site_recording_chunk_frames = 64;

struct SiteRecordingOptions {
    std::size_t decimation = 1;      // M: simulation steps per recorded sample
    double pass_hz = 0, stop_hz = 0; // the force's band (transfer/transfer.h); stop_hz <= 0: the one-step impulse
};
// M = floor(1 / (2 R k)) (recording rate >= 2 R, so the transition band
// R / 2 .. 1 / (2 M k) is at least R / 2 wide and the sinc stays short:
// about 5 / R s each side), pass R / 2, stop half the recording rate.
SiteRecordingOptions site_recording_options(double time_step_s, double search_rate_hz);
// Steps the sinc's delay adds to a simulation (0 for the one-step impulse).
std::size_t site_recording_delay_steps(double time_step_s, const SiteRecordingOptions &o);

struct SiteRecording {
    double rate_hz = 0;         // 1 / (M k)
    std::size_t decimation = 1; // M
    // traces[i][n]: displacement (m per N s) at site i, time (n M + 1) k after
    // the impulse; ceil(steps / M) samples cover the `steps` of the window.
    std::vector<std::vector<double>> traces;
};

// Runs `sim` (fresh: no sources, receivers or steps yet) with the impulse at
// `source` for `steps` steps of the impulse's response (plus the sinc's delay)
// and records the sites. Throws std::runtime_error on divergence (the
// simulation's whole-field scans).
SiteRecording record_sites(engine::Simulation &sim, Point source, const std::vector<Point> &sites, std::size_t steps,
                           const SiteRecordingOptions &o);

// The recordings of every source (each its own impulse, as record_sites):
// the sources side by side in the engine's lanes where the plate allows
// (engine/lanes.h: clamped and supported edges, no thick plate; equal to
// record_sites to round-off), else one Simulation each, in parallel.
// `options`: one simulation's (single_core_options). progress(done, total)
// as sources finish. Throws engine::SourceFailure naming the source.
std::vector<SiteRecording> record_sites_of(std::shared_ptr<const engine::PlateOperator> plate,
                                           const engine::SimulationOptions &options, const std::vector<Point> &sources,
                                           const std::vector<Point> &sites, std::size_t steps,
                                           const SiteRecordingOptions &o,
                                           const std::function<void(std::size_t, std::size_t)> &progress);

// The recordings at the search rate: soxr from the recording rate to
// `rate_hz`, each cut to the length the full-rate `steps` would give
// (round(steps k rate_hz)).
std::vector<std::vector<double>> site_responses_at(const SiteRecording &rec, double time_step_s, std::size_t steps,
                                                   double rate_hz);

} // namespace calib::pipeline
