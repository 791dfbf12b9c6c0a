// What a panel may differ by from the plate a table was calibrated on (the
// [tolerance] section), the ensemble a robust design averages over
// ([calibration] robust = { ... }), one perturbed plate, and the figures a
// table keeps on it (docs/robustness.md). Plain data: the scene parser fills
// the specs, pipeline/robustness/tolerance.h builds and verifies the perturbed plates.
#pragma once
#include "physics/material.h"
#include "pipeline/data/geometry.h"

#include <cmath>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace calib::pipeline {

// [tolerance]: half-widths of the box around the nominal plate.
struct ToleranceSpec {
    double youngs_rel = 0;    // E within +-youngs_rel (relative)
    double density_rel = 0;   // rho within +-density_rel
    double thickness_rel = 0; // d within +-thickness_rel
    // Loss factor eta at the pulse centre over [min, max]; unset: the
    // material's stated range, if it has one.
    std::optional<double> loss_min, loss_max;
    std::vector<double> loss_scale;          // extra cases: the nominal loss times each (e.g. 0.5, 2)
    double exciter_position_m = 0;           // every exciter within this distance of its table position
    double temperature_k = 0;                // +-K from the calibration temperature, through E
    std::optional<double> youngs_per_kelvin; // dE/E/dT (1/K); unset: the material's
    // The device plays the table at the panel's speed ratio (hapticd's
    // [panel], common/haptic_stretch.h): every plate whose wave speed differs
    // is verified a second time with the table stretched by that ratio.
    bool speed_compensation = false;
    unsigned random_cases = 0; // seeded random combinations (the study adds them)
    uint64_t seed = 1;
};

// dE/E/dT (1/K) of a panel: the box's, where it states one, else the
// material's (0: unknown, a custom material without E_per_k).
inline double panel_youngs_per_kelvin(const ToleranceSpec *box, const physics::Material &m)
{
    return box && box->youngs_per_kelvin ? *box->youngs_per_kelvin : m.youngs_per_kelvin;
}

// [calibration] robust = { ... }: the plates the drives are designed over
// (the nominal plate is always a member).
struct RobustSpec {
    std::vector<double> loss;         // loss factors eta at the pulse centre
    std::vector<double> youngs_scale; // E scalings (e.g. 0.97, 1.03)
    // Level of each focus: the scene's amplitude on the nominal plate
    // (false), or the level that leaves the threshold the same margin on
    // both sides over every member plate: the weakest focal peak above it
    // by the factor the strongest peak elsewhere is below it (true).
    bool margin_level = false;
};

// One perturbed plate: what changes against the nominal one.
struct Perturbation {
    std::string name;   // "E +3 %", "loss 0.030", ...
    std::string factor; // the tolerance it belongs to ("E", "rho", ...; "combined", "nominal")
    double youngs_scale = 1, density_scale = 1, thickness_scale = 1;
    double loss_scale = 1;                // multiplies the loss (sigma0 and sigma1 at the same kappa)
    double temperature_k = 0;             // folded into youngs_scale by the builder of the case
    std::vector<Point> exciter_offsets_m; // per exciter (empty: none)
    bool zero() const
    {
        bool moved = false;
        for (Point p : exciter_offsets_m)
            moved = moved || p.x_m != 0 || p.y_m != 0;
        return youngs_scale == 1 && density_scale == 1 && thickness_scale == 1 && loss_scale == 1 && !moved;
    }
};

// What a table keeps on one plate (from its verification).
struct CaseFigures {
    double worst_whole_area_contrast_db = INFINITY;
    uint32_t worst_focus_id = 0;
    double min_peak_m = INFINITY, max_peak_m = 0;
    double max_offset_m = 0; // perceived offset distance, worst focus
    double max_lead_time_s = 0;
    unsigned foci_passing = 0; // foci that pass the verdict (data/verdict.h FocusMetrics::passes)
    unsigned foci_failing = 0;
    unsigned area_crossings = 0; // foci whose field beyond lambda/2 reaches the threshold somewhere
    double peak_per_energy = 0;  // mean over foci of peak / sqrt(drive energy) (m / (N s^0.5))
};

struct ToleranceCase {
    Perturbation perturbation;
    CaseFigures table;                         // the table as written
    std::optional<CaseFigures> nominal_design; // with a robust design: the plain design on the same plate
    bool rescaled = false; // H from the nominal one (pipeline/robustness/tolerance.h), not simulated
    // The plate's kappa over the nominal plate's (E, rho, d, temperature): the
    // speed ratio a device measures and compensates.
    double speed_ratio = 1;
    // With speed compensation, on a plate whose speed ratio is not 1: the
    // table (and the plain design) stretched by it (common/haptic_stretch.h).
    std::optional<CaseFigures> compensated, nominal_design_compensated;
    double seconds = 0;
};

// The table over the tolerance box (and, with a robust design, the plain
// design beside it).
struct ToleranceReport {
    CaseFigures nominal;                       // the table on the nominal plate
    std::optional<CaseFigures> nominal_design; // robust runs: the plain design on the nominal plate
    std::vector<ToleranceCase> cases;
    CaseFigures worst; // worst of every figure over the cases
    std::optional<CaseFigures> nominal_design_worst;
    // With speed compensation: the worst over the box when the device plays
    // each plate at its speed ratio (the compensated figures where there are).
    std::optional<CaseFigures> compensated_worst, nominal_design_compensated_worst;
    double seconds = 0; // the box's verification
    // Robust design: the ensemble's members and what designing over them cost.
    std::vector<std::string> ensemble;
    double ensemble_seconds = 0;
};

} // namespace calib::pipeline
