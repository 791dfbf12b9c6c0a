// What the verification measures at each focus (FocusMetrics) and the
// verdict on it (FocusMetrics::passes, the one rule every output and every
// optimisation uses) with the gains over which it holds (gain_range), the
// summary over the foci, and a verification whole: per-focus figures, traces
// at the foci, fields for the report.
#pragma once
#include "pipeline/data/geometry.h"

#include <haptic_table.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace calib::pipeline {

// a over b in dB, 20 log10(a / b), b floored at 1e-300: every contrast and
// margin of the verdict.
inline double ratio_db(double a, double b) { return 20 * std::log10(a / std::max(b, 1e-300)); }

struct FocusMetrics {
    uint32_t id = 0;
    Point at;
    double peak_m = 0; // max |w| at the focus while its stored signals play
    // Playback start to the focal peak: the lead time (what a person waits,
    // before device latency; data/lead_time.h). The table stores it per
    // focus; metrics.json writes it as peak_time_s and lead_time_s.
    double lead_time_s = 0;
    double max_other_foci_m = 0;       // max |w| at every other focus farther than lambda/2, at all times
    double other_foci_contrast_db = 0; // 20 log10(peak / max_other)
    double spot_diameter_m = 0;        // circle of the area around the focus where |w| >= peak / 2
    // At the focus instant: the largest |w| on the plate farther than lambda/2
    // from the focus, and the focus's margin over it (what the seed's Fig. 4 shows).
    double max_elsewhere_m = 0;
    double field_contrast_db = 0;
    // At all times of the playback and its decay: the largest |w| in the active
    // area farther than lambda/2 from the focus (on the observation lattice),
    // where it is, and the focus's margin over it.
    double max_whole_area_m = 0;
    Point whole_area_max_at;
    double whole_area_contrast_db = 0;
    // Centroid of the active area where |w| reaches the threshold at some time,
    // minus the focus (m): where a person feels the pulse, and how far off.
    Point perceived_offset_m;
    double perceived_offset_distance_m = 0;
    double area_above_threshold_m2 = 0;
    double lambda_half_m = 0; // half the A0 wavelength at the pulse centre
    bool crosses_threshold = false;
    bool others_below_threshold = false;
    bool whole_area_below_threshold = false; // nowhere beyond lambda/2 reaches the threshold
    bool whole_area = false;                 // the whole-area figures were measured
    // The stored signals' sound on axis 0.5 m above the plate centre (baffled
    // plate, verification/radiation.h): A-weighted exposure level L_AE (dB re
    // 20 uPa^2 s); measured with the whole-area figures (H with its lattice).
    double sound_exposure_dba = 0;
    bool sound = false;

    // The verdict, the one rule every output and every optimisation uses: the
    // focus crosses the threshold and nothing farther than lambda/2 from it
    // reaches the threshold at any time: not another focus and, where the
    // whole area was measured (through H), no point of the active area. The
    // forward path ([effects.finger]) measures the foci only, so its verdict
    // covers the foci only (verdict_scope() says which).
    bool passes() const
    {
        return crosses_threshold && others_below_threshold && (!whole_area || whole_area_below_threshold);
    }
    const char *verdict_scope() const { return whole_area ? "whole area" : "foci only"; }
    // The safe range: the gains g (applied to the stored samples, 1 = as
    // stored) at which the focus passes the verdict above. The system is
    // linear in the drive, so at gain g every |w| is g times the measured one
    // and the verdict's three comparisons become lo <= g (g peak >= threshold)
    // and g < hi (g x the largest |w| it judges beyond lambda/2 < threshold):
    // lo = threshold / peak, hi = threshold / that largest |w| (+infinity
    // where nothing it judges moves). lo >= hi: no gain passes. The one home
    // of this rule: the table stores it (table_writer.cpp), every report
    // shows it (safe_range_text). Gains past HAPTIC_TABLE_RANGE_MAX_GAIN (120
    // dB, what a table holds) are none a device plays, since every nonzero
    // int16 sample clips past 32767: hi beyond it is unbounded, and a focus
    // that would need a lo beyond it passes at no gain ({max, max}).
    haptic_gain_range gain_range(double threshold_m) const;
    // The focus's margin over what the verdict judges (dB): the whole-area
    // contrast, or over the other foci where only they were measured.
    double margin_db() const { return whole_area ? whole_area_contrast_db : other_foci_contrast_db; }
    // Why a focus fails, in one line, with where its ghost is and how far it
    // goes (empty when it passes).
    std::string failure(double threshold_m) const;
};

// How many foci pass the verdict, and the worst focus (least whole-area
// contrast, else least contrast over the other foci).
struct VerdictSummary {
    std::size_t passing = 0, total = 0;
    std::size_t worst = 0;
    double worst_margin_db = 0; // foci[worst].margin_db()
    bool all_pass() const { return passing == total; }
};
VerdictSummary summarize_verdict(const std::vector<FocusMetrics> &foci);

// Whether any gain passes: lo < hi (FocusMetrics::gain_range).
inline bool any_gain_passes(const haptic_gain_range &r) { return r.lo < r.hi; }
// A gain in dB relative to the stored level, 20 log10 g.
inline double gain_db(double g) { return 20 * std::log10(g); }
// The safe range as every output writes it, in dB relative to the stored
// level: "-6.0 .. +4.4", "-6.0 .. unbounded" (hi = +infinity), "none"
// (lo >= hi: no gain passes).
std::string safe_range_text(const haptic_gain_range &r);

struct Verification {
    std::vector<FocusMetrics> foci;
    double trace_rate_hz = 0;
    // traces[f][g]: displacement at focus g while focus f is driven (m).
    std::vector<std::vector<std::vector<double>>> traces;
    // snapshots[f]: |w| field at focus f's peak on the grid below (row-major):
    // the observation lattice of H, or the plate grid on the forward path.
    std::vector<std::vector<float>> snapshots;
    int grid_nx = 0, grid_ny = 0; // intervals per axis (points - 1)
    double grid_h_m = 0;
    // Whole-area data for the report (H path only; empty otherwise):
    // max_abs[f][n]: max over all times of |w| at lattice point n (same grid as
    // the snapshots) while focus f plays: the per-focus field of ghosts. The
    // per-focus whole-area contrast map over the active area is
    // foci[f].whole_area_contrast_db at foci[f].at.
    std::vector<std::vector<float>> max_abs;
    // The worst focus (least whole-area contrast) over time: frames[s][n] is
    // w (signed, m) at lattice point n at time s / frame_rate_hz from the start
    // of playback, through the drive and its decay.
    std::size_t worst_focus = 0;
    double frame_rate_hz = 0;
    std::vector<std::vector<float>> frames;
};

} // namespace calib::pipeline
