// measurements.toml (docs/bench.md, "The plan and measurements.toml"): what
// `calibgen measure-plan` wrote and a lab filled in (or wrote by hand): the
// plan played, the exciters' nominal positions, the recording, and where each
// sensor sat and what it measured. Read with both WAV files and checked
// against the scene; every refusal is one line naming the file and the key
// (SceneError), e.g. "m.toml: sensor[2].channel: 5 but rec.wav has 4 channels".
#pragma once
#include "pipeline/bench/bench_model.h"
#include "pipeline/data/geometry.h"
#include "scene/scene.h"
#include "scene/wav_file.h"

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace calib::scene {

// What a sensor measures (the bench model's: the order of the displacement's time derivative).
using pipeline::SensorQuantity;

struct MeasuredSensor {
    pipeline::Point at;      // position_m
    std::size_t channel = 0; // of the recording
    SensorQuantity quantity = SensorQuantity::acceleration;
    std::optional<double> units_per_count; // SI units per full-scale-normalised sample; unset: unknown
};

struct Measurements {
    std::string file;  // the toml, as given
    std::string scene; // its `scene` key ("" if absent): informative

    // [excitation]
    std::string plan_path; // resolved against the toml's directory
    WavData plan;          // frames x exciters, in [-1, 1)
    double rate_hz = 0;
    std::vector<std::size_t> start_frames; // exciter e's sweep starts at start_frames[e] (plan channel e)
    double sweep_f1_hz = 0, sweep_f2_hz = 0;
    double sweep_s = 0, gap_s = 0;

    // [exciters]
    std::vector<pipeline::Point> exciters; // nominal positions
    double force_full_scale_n = 1;

    // [recording]
    std::string recording_path; // resolved
    WavData recording;          // frames x channels, same rate as the plan, at least as long

    std::vector<MeasuredSensor> sensors; // [[sensor]], in the file's order

    std::size_t sweep_frames() const;   // round(sweep_s rate)
    std::size_t segment_frames() const; // sweep and gap: one exciter's part of the recording
    // The samples exciter e played: plan channel e over its sweep.
    std::vector<double> excitation(std::size_t e) const;
    // What sensor s recorded while exciter e played: its recording channel over
    // exciter e's segment (sweep and gap), in recorded units.
    std::vector<double> segment(std::size_t s, std::size_t e) const;
};

// A recording channel with more samples than this at |x| >= 0.999 of full
// scale is refused as clipped.
constexpr std::size_t clipped_samples_allowed = 4;

// Reads `path` and the two WAV files it names, checked against the scene's
// plate and [exciters]. Throws SceneError. RecordingRead::skip reads all but
// the recording (`calibgen bench-record` writes it).
enum class RecordingRead { read, skip };
Measurements load_measurements(const std::string &path, const Scene &scene,
                               RecordingRead recording = RecordingRead::read);

} // namespace calib::scene
