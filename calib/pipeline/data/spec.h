// What a scene asks of the calibration (the [active_area], [exciters],
// [foci], [pulse] and [calibration] sections; docs/scene-format.md). Plain
// data: the scene parser fills it and checks each key, the pipeline reads it.
#pragma once
#include "pipeline/data/geometry.h"

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace calib::pipeline {

// [active_area]: the transparent touch area and the frame.
struct ActiveAreaSpec {
    Rect area;                   // x0, y0, x1, y1 (m), plate origin at the lower-left corner
    double frame_margin_m = 0.0; // no exciter closer than this to the plate edge
    double clearance_m = 0.0;    // no exciter closer than this to the active area
};

enum class PlacementMode { random, regular, fixed };
enum class PlacementCriterion { contrast, distance_variety };

// [exciters]
struct ExcitersSpec {
    unsigned count = 8;
    PlacementMode placement = PlacementMode::random;
    PlacementCriterion criterion = PlacementCriterion::contrast;
    uint64_t seed = 1;
    double min_spacing_m = 0.05;
    double force_full_scale_n = 1.0; // force an exciter applies at digital full scale
    std::vector<Point> positions;    // placement = "fixed"
    // placement = "fixed": each exciter's force per count relative to
    // force_full_scale_n (a bench fit measures them, docs/bench.md); empty: all 1.
    // The one place they act is the transfer matrix (transfer/transfer.h) and
    // the forward path's forces: a drive is designed for the exciter it plays on.
    std::vector<double> force_gains;
    double force_gain(std::size_t c) const { return c < force_gains.size() ? force_gains[c] : 1.0; }
    std::optional<double> site_spacing_m; // candidate lattice; default lambda/8 at the pulse centre
    unsigned restarts = 8;
    unsigned iterations = 1500;
    // Rounds of the search by the verdict (pipeline/placement_verdict.h): each adds the
    // ghosts of the best placement so far to the contrast model and searches
    // again. 0: the contrast model's choice is kept (no search by the verdict).
    unsigned verdict_rounds = 8;
    // The contrast the search maximizes: over all times (the seed's Fig. 8
    // criterion) or at the focus instant only (its Fig. 4 snapshots).
    bool contrast_at_focus_instant = false;
    // At most this many foci weigh in the placement search (placement/focus_subset.h);
    // unset: the default cap there.
    std::optional<unsigned> placement_foci;
};

// [foci]
struct FocusPoint {
    uint32_t id = 0;
    Point at;
};
struct FociSpec {
    std::vector<FocusPoint> points; // from grid = [nx, ny] or pitch_m inside the active area, or explicit points
    std::optional<double> pitch_m;  // the square grid's pitch (pitch_m = ...)
};

// [calibration] method: how the drives are designed from the transfer matrix
// (docs/scene-format.md): time reversal (the seed's, the matched filter) or a
// regularised least-squares inverse filter (pipeline/design/inverse_filter.h).
enum class DriveMethod { time_reversal, inverse_filter };
// [calibration] exciter_gains (time reversal): each exciter's level per focus
// chosen for the whole-area verdict (design/exciter_gains.h), or all equal
// (the seed's time reversal).
enum class ExciterGainsMode { minimax, equal };

// [calibration]
struct CalibrationSpec {
    double window_s = 0.2;          // recording window after the pulse starts at a focus
    double truncate_fraction = 0.3; // the seed's 30 %
    double output_rate_hz = 48000;
    std::string sample_format = "s16";
    double threshold_m = 5e-6; // perception threshold (the seed's 5 um)
    bool dither = true;
    std::optional<double> accuracy; // target relative phase-velocity error (docs/ACCURACY.md)
    double verify_tail_s = 0.1;     // verification runs this long after the drive ends
    DriveMethod method = DriveMethod::time_reversal;
    ExciterGainsMode exciter_gains = ExciterGainsMode::minimax;
    // Playback start to the focal peak (s); unset: where time reversal puts it
    // with the kept window truncate_fraction x window_s (pipeline/data/lead_time.h).
    std::optional<double> lead_time_s;
    // Inverse filter: Tikhonov weight relative to the largest eigenvalue of the
    // drive's Gram matrix H^T H (pipeline/design/inverse_filter.h); >= 0.
    double regularization = 1e-4;
    // Inverse filter: the drive continues this long after the focal instant
    // (s), designed with the rest to hold the whole active area at zero, so
    // it takes the reverberation out of the plate (active damping); 0: the
    // drive ends at the focal instant.
    double active_damping_s = 0;
};

} // namespace calib::pipeline
