// What `calibgen measure-plan` chooses and writes (docs/bench.md, "The plan
// and measurements.toml"): one exponential sweep per exciter in turn
// (pipeline/signal/sweep.h), its band, length and the silence after it chosen
// from the scene, and the measurements.toml a lab fills in.
//
// The choices, each a rule the docs state:
// - band: the pulse's band [lo, hi] with hi = pulse_max_frequency_hz (its -40 dB
//   top, the one the grid resolves) and lo = max(2 centre - hi, centre / 4)
//   (the lower edge calibrate's effect assessment uses), widened to
//   f1 = lo / 2, f2 = min(1.5 hi, 0.45 rate): the sweep's fades and the
//   deconvolution's taper stay outside the pulse band.
// - gap: the time the scene's loss law takes to bring f1 (the slowest decay
//   of the band: the law's decay rate grows with frequency) down by --snr-db,
//   times 1.25, plus 50 ms.
// - length: the longest of (a) the SNR rule, deconvolved SNR = recording SNR +
//   10 log10(T B), for --snr-db from --recording-snr-db, (b) the second
//   harmonic's response, assumed 20 dB below the linear one, decayed by the
//   remaining (snr - 20) dB at 2 f1 before it reaches t = 0 (it lands
//   L ln 2 early), clamped to [1, 30] s; a length cut at 30 s says the SNR it
//   then reaches.
// - lengths (sweep and gap) rounded up to whole 10 ms: whole frames at 44.1
//   and 48 kHz, so the keys written in seconds give the frames back exactly.
// - level: --level-dbfs (peak of the sweep), PCM_16 as boards play.
// - a lead-in of 0.25 s of silence before the first sweep (the recording's
//   noise floor, and time for the streams to settle).
#pragma once
#include "pipeline/data/geometry.h"
#include "pipeline/signal/sweep.h"
#include "scene/scene.h"

#include <optional>
#include <string>
#include <vector>

namespace calib::scene {

struct PlanOptions {
    std::optional<double> rate_hz; // default: the scene's [calibration] output_rate_hz
    double level_dbfs = -6;
    double snr_db = 60;           // wanted SNR of the deconvolved responses, and the decay the gap waits for
    double recording_snr_db = 30; // expected SNR of the raw recording
    // Where the exciter positions come from, for messages (a table's path;
    // default: "<scene>: exciters.positions_m").
    std::string positions_from;
};

struct MeasurementPlan {
    pipeline::SweepSpec sweep;
    pipeline::PlanLayout layout;
    double pulse_lo_hz = 0, pulse_hi_hz = 0;
    double gap_s = 0, lead_s = 0;
    double decay_f1_s = 0; // the loss law's time for f1 to fall by snr_db
    double sweep_s_snr = 0, sweep_s_distortion = 0;
    std::string length_rule; // which rule set the length, in words
    double predicted_snr_db = 0;
    std::vector<pipeline::Point> exciters;
    double force_full_scale_n = 1;
    double total_s() const { return double(layout.total_frames) / sweep.rate_hz; }
};

// Throws SceneError naming the key (a scene without [exciters], [pulse] or
// [plate.loss], no rate, a rate too low for the pulse band) and
// std::invalid_argument naming the option or where the positions came from
// (a level or SNR out of range, positions not one per exciter or off the
// plate): one line either way.
MeasurementPlan plan_measurement(const Scene &scene, const std::vector<pipeline::Point> &exciters,
                                 const PlanOptions &options);

// The plan's samples: PCM_16 counts, interleaved [frame][exciter].
std::vector<int16_t> plan_pcm16(const MeasurementPlan &plan);

// The text of measurements.toml for a plan written as `plan_file` next to it:
// a comment block (scene, its hash, the command, what to fill in), then the
// keys the reader (measurements.h) reads, [[sensor]] tables left to fill in.
std::string measurements_toml(const MeasurementPlan &plan, const std::string &plan_file, const std::string &scene_path,
                              const std::string &scene_hash, const std::string &command);

} // namespace calib::scene
