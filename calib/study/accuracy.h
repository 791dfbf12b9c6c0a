// What accuracy costs, measured: the phase-velocity error of the plate
// scheme from the simulation itself, and a sweep of a scene's knobs through
// the whole calibration (`calibgen study accuracy`), each setting against
// the error and cost models' predictions (model/). docs/ACCURACY.md has the
// method and the measured results.
#pragma once
#include "engine/simulation.h"
#include "model/cost_model.h"
#include "physics/material.h"
#include "scene/scene.h"

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace calib::study {

// The plate model: Kirchhoff, or the thick-plate (Mindlin) effect
// (effects.thick_plate; the engine refuses it with loss or free edges).
enum class PlateModel { kirchhoff, mindlin };
const char *model_name(PlateModel m);

// One point of the accuracy/time trade.
struct DispersionSetting {
    double points_per_wavelength = 12; // per Kirchhoff A0 wavelength at f_max (as scene.cpp builds the grid)
    engine::Precision precision = engine::Precision::f32;
    double courant = 0.95;
    PlateModel model = PlateModel::kirchhoff;
};

// --- (a) Phase velocity measured from the simulation -------------------------
// A simply supported strip (ny = 8 nx cells) of the material and thickness,
// grid spacing h = lambda_Kirchhoff(f) / N, started in its discrete (2, 1)
// mode and left to ring; the mode's angular frequency is fitted from a
// receiver trace (the leapfrog recurrence u+ + u- = 2 cos(omega k) u, least
// squares). Two strips whose wavenumbers bracket the exact A0 wavenumber at f
// give, by log-log interpolation, the scheme's wavenumber at f, hence its
// phase velocity, compared with the exact Rayleigh-Lamb A0 speed. Kirchhoff
// only (the strip runs the Kirchhoff engine).
struct PhaseMeasurement {
    double f_hz = 0;
    double h_m = 0;
    double exact_m_s = 0;      // exact A0 phase velocity at f
    double measured_m_s = 0;   // the scheme's phase velocity at f
    double relative_error = 0; // measured / exact - 1
    double seconds = 0;        // wall time of the measurement
};
PhaseMeasurement measure_phase_velocity(const physics::Material &m, double thickness_m, double f_hz,
                                        const DispersionSetting &s);

// --- The study --------------------------------------------------------------
struct StudyOptions {
    std::vector<double> points_per_wavelength = {6, 8, 10, 12, 16, 20, 24};
    std::vector<double> courants = {0.5, 0.8};
    std::vector<double> window_factors = {0.5, 1.5};
    bool include_precision = true, include_model = true;
    unsigned search_restarts = 2, search_iterations = 300; // the reference's placement search (reduced), scene seed
    bool quiet = false;
};

struct StudyRow {
    std::string knob; // "ppw", "precision", "courant", "window", "model", "reference"
    DispersionSetting setting;
    double window_s = 0;
    bool ran = false;
    std::string note;
    // The --dry-run models at this setting (model/).
    struct Predicted {
        double h_m = 0, time_step_s = 0;
        int nx = 0, ny = 0;
        double phase_error = 0, seconds = 0, memory_mb = 0;
    } predicted;
    PhaseMeasurement phase;
    // Peak |w| of the focus-instant snapshot, located to sub-cell precision
    // (parabola through the largest node and its neighbours on each axis).
    double focus_position_error_m = 0; // worst over foci: |that peak - focus|
    // Worst over foci: that peak's distance to the reference's peak. Every
    // setting plays the reference's exciter placement, so this and the
    // contrast change measure the grid alone and go to zero as it is refined.
    double focus_shift_m = 0;
    // Worst over foci of the pipeline's contrast_db (peak / max at the other
    // foci); a one-focus scene has none, so there it is the snapshot contrast
    // 20 log10(peak / max |w| farther than lambda/2 from the focus).
    double contrast_db = 0;
    double contrast_change_db = 0;                     // worst |contrast - reference contrast| over foci
    double wall_s = 0;                                 // calibrate() wall time
    double simulate_s = 0, search_s = 0, verify_s = 0; // its stages (pipeline::StageTimes)
    double peak_rss_mb = 0;                            // peak resident memory during calibrate()
};

struct StudyResult {
    std::string scene_file, scene_name;
    double f_max_hz = 0;
    double lambda_f_max_m = 0;
    model::CostModel cost;                 // at the first swept setting
    std::vector<pipeline::Point> exciters; // the reference's placement, which every setting plays
    std::vector<StudyRow> rows;
};

using StudyProgress = std::function<void(const std::string &)>;
StudyResult run_accuracy_study(const std::string &scene_path, const StudyOptions &options,
                               const StudyProgress &progress = {});

// DIR/accuracy.csv, DIR/accuracy.svg, DIR/accuracy.png, DIR/accuracy.md;
// returns the markdown (also printed by the command).
std::string write_study_report(const StudyResult &r, const std::string &dir);

} // namespace calib::study
