// `calibgen study latency SCENE --report DIR`: what the lead time (playback
// start to the focal peak, pipeline/data/lead_time.h) costs in focusing, for time
// reversal and the inverse filter side by side. One placement and one
// transfer matrix H serve every case (same scene, same exciters); each case
// designs the drives of every focus at one lead time with one method, sets
// their level for the target amplitude and verifies them over the whole
// active area at all times (pipeline/verification/verification.h). docs/REPRODUCTION.md
// holds the Fig. 7 results.
#pragma once
#include "pipeline/verification/focus_ceiling.h"
#include "pipeline/verification/multitouch.h"
#include "pipeline/placement/placement.h"
#include "pipeline/data/spec.h"

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace calib::study {

struct LatencyOptions {
    std::vector<double> lead_times_s = {0.010, 0.015, 0.020, 0.025, 0.030, 0.040, 0.050, 0.060, 0.070, 0.080};
    std::vector<double> regularizations; // empty: the scene's
    bool multitouch = true;              // verify every pair of foci too
    bool triples = false;                // ... and every triple of foci >= lambda/2 apart
    // ... and, in the inverse filter's cases, each of those sets designed
    // jointly under the superposition's budget (pipeline/verification/multitouch.h)
    bool joint = false;
    bool quiet = false;
};

struct LatencyRow {
    pipeline::DriveMethod method = pipeline::DriveMethod::time_reversal;
    bool scene_default = false;          // lead_time_s unset: the scene's kept window
    double lead_target_s = 0;            // what the drives aim at
    double regularization = 0;           // inverse filter only
    double lead_measured_s = 0;          // latest focal peak over the foci
    double worst_whole_area_db = 0;      // min over foci of the whole-area contrast, all times
    double worst_other_foci_db = 0;      // min over foci of the contrast over the other foci
    double min_peak_m = 0;               // smallest focal peak at the stored level
    double margin_m = 0;                 // min over foci of threshold - max |w| beyond lambda/2 (all times)
    bool all_cross = false;              // every focus reaches the threshold
    bool all_alone = false;              // ... and nothing beyond lambda/2 in the active area does
    double min_peak_per_root_energy = 0; // m / (N s^0.5), worst focus
    double max_energy_n2s = 0;           // largest drive energy at the stored level
    double max_out_of_band = 0;          // largest fraction of drive energy above the pulse band
    // Two fingers (pipeline/verification/multitouch.h): pairs of foci >= lambda/2 apart
    // superposed with the firmware's energy normalisation.
    std::size_t pairs = 0, pairs_failing = 0;
    uint32_t worst_pair[2] = {0, 0};              // focus ids
    double worst_pair_margin_m = 0;               // min(weakest focus - threshold, threshold - max elsewhere)
    std::size_t triples = 0, triples_failing = 0; // three fingers (LatencyOptions::triples)
    uint32_t worst_triple[3] = {0, 0, 0};
    double worst_triple_margin_m = 0;
    double max_sound_dba = 0; // loudest focus: L_AE on axis at 0.5 m (pipeline/verification/radiation.h)
    std::vector<pipeline::MultiTouchCase> sets; // every pair (and triple) verified, superposed (and joint)
    double seconds = 0;                         // design and verification wall time
    std::string error;                          // a case that failed (refused lead time, ...)
};

struct LatencyResult {
    std::string scene_file, scene_name;
    double threshold_m = 0;
    double crossing_s = 0; // the lead time's lower bound for these exciters
    // An ideal isotropic focus of the scene's pulse on its plate, on the same
    // criterion (pipeline/verification/focus_ceiling.h): what no layout of exciters beats
    // by forming a round focus.
    pipeline::FocusCeiling ceiling;
    std::vector<pipeline::Point> exciters;
    std::vector<uint32_t> focus_ids; // the scene's, by index
    double transfer_s = 0, placement_s = 0;
    std::vector<LatencyRow> rows;
};

using LatencyProgress = std::function<void(const std::string &)>;
LatencyResult run_latency_study(const std::string &scene_path, const LatencyOptions &options,
                                const LatencyProgress &progress = {});

// DIR/latency.csv, DIR/latency.svg, .png (worst whole-area contrast against
// lead time), DIR/latency-efficiency.svg (focal peak per root drive energy),
// DIR/latency.md; with joint designs also DIR/multitouch.csv (every set of
// every case) and DIR/multitouch.svg, .png (joint against superposed margin,
// per set), their table in latency.md. Returns the markdown.
std::string write_latency_report(const LatencyResult &r, const std::string &dir);

} // namespace calib::study
