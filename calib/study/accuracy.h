// What accuracy costs (issue #6 part 1): measure the phase-velocity error of
// the plate scheme from the simulation itself, predict it (and the run time
// and memory of a calibration) from a model, pick the cheapest setting that
// meets a target, and sweep a scene's knobs (`calibgen study accuracy`).
// docs/ACCURACY.md has the method and the measured results.
#pragma once
#include "engine/simulation.h"
#include "physics/material.h"
#include "scene/scene.h"

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace calib::study {

// The plate model. Only Kirchhoff exists in the engine today; the thick-plate
// (Mindlin) effect is the hook: a setting asking for it is reported as not
// available rather than silently run as Kirchhoff.
enum class PlateModel { kirchhoff, mindlin };
const char *model_name(PlateModel m);
bool model_available(PlateModel m);

// One point of the accuracy/time trade.
struct DispersionSetting {
    double points_per_wavelength = 12;  // per Kirchhoff A0 wavelength at f_max (as scene.cpp builds the grid)
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
// phase velocity, compared with the exact Rayleigh-Lamb A0 speed.
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

// --- Error model ----------------------------------------------------------
// The 13-point scheme with leapfrog along a grid axis satisfies
// sin(omega k / 2) = 2 mu sin^2(beta h / 2), mu = kappa k / h^2: solved for
// beta at omega = 2 pi f, its phase velocity omega / beta against the exact
// A0 speed (so the Kirchhoff-vs-Lamb model error is included).
double predicted_phase_error(const physics::Material &m, double thickness_m, double f_hz, double h_m,
                             double time_step_s);

// --- Cost model -------------------------------------------------------------
// Seconds per step of one simulation on one core, timed on the scene's own
// operator with the receivers and sources each pipeline stage uses (a quick
// timing, the fastest of three runs of ~1.5e7 node-steps per precision and
// stage): the reciprocity simulations record at every
// candidate site, the verification drives the exciters and records the foci.
struct CostModel {
    double seconds_per_step_simulate[2] = {0, 0};  // [precision: f32, f64]
    double seconds_per_step_verify[2] = {0, 0};
    double seconds_per_node_step[2] = {0, 0};      // the simulate figure per node, for reports
    int threads = 1;
};
CostModel time_cost_model(const std::shared_ptr<const engine::PlateOperator> &plate, std::size_t sites,
                          std::size_t foci, std::size_t exciters);

// What one calibration of a scene costs and how accurate it is, predicted
// without running it.
struct Prediction {
    DispersionSetting setting;
    double f_max_hz = 0;
    double h_m = 0;
    int nx = 0, ny = 0;
    double time_step_s = 0;
    double steps_per_window = 0;
    double phase_error = 0;   // predicted relative phase-velocity error at f_max
    double seconds = 0;       // predicted wall time of `calibrate`
    double memory_mb = 0;     // predicted peak resident memory
    double emitters = 0, sites = 0;
};
// `scene` as given (its [simulation] settings); `setup` must be build_plate(scene).
// Times the cost model on the way (returned in *cost if given).
Prediction predict_calibration(const scene::Scene &scene, const scene::PlateSetup &setup,
                               CostModel *cost = nullptr);

// The cheapest points-per-wavelength (scene's precision and Courant factor)
// whose predicted |error| at f_max is <= target, and stays so for every finer
// grid up to 80 points per wavelength. Throws std::invalid_argument naming
// the floor when even that is not enough (the Kirchhoff model error).
struct Choice {
    double points_per_wavelength = 0;  // as the scene asks (nominal)
    double effective_ppw = 0;          // lambda / h of the grid make_grid builds (h divides the plate)
    double h_m = 0;
    double predicted_error = 0;
};
Choice choose_points_per_wavelength(const scene::Scene &scene, double target);
// Applies calibration.accuracy (if set) to scene.simulation; returns the choice.
std::optional<Choice> apply_accuracy_target(scene::Scene &scene);

// `calibgen calibrate --dry-run`: the setting the scene gets (after its
// accuracy target, if any), the predicted phase error at f_max, run time and
// peak memory of the calibration, without running it. Throws like load_scene.
std::string dry_run_summary(const std::string &scene_path);

// --- The study --------------------------------------------------------------
struct StudyOptions {
    std::vector<double> points_per_wavelength = {6, 8, 10, 12, 16, 20, 24};
    std::vector<double> courants = {0.5, 0.8};
    std::vector<double> window_factors = {0.5, 1.5};
    bool include_precision = true, include_model = true;
    unsigned search_restarts = 2, search_iterations = 300;  // reduced placement search, same seed
    bool quiet = false;
};

struct StudyRow {
    std::string knob;  // "ppw", "precision", "courant", "window", "model", "reference"
    DispersionSetting setting;
    double window_s = 0;
    bool ran = false;
    std::string note;
    Prediction predicted;
    PhaseMeasurement phase;
    // Peak |w| of the focus-instant snapshot, located to sub-cell precision
    // (parabola through the largest node and its neighbours on each axis).
    double focus_position_error_m = 0;  // worst over foci: |that peak - focus|
    double focus_shift_m = 0;           // worst over foci: that peak's distance to the reference's peak
    // Worst over foci of the pipeline's contrast_db (peak / max at the other
    // foci); a one-focus scene has none, so there it is the snapshot contrast
    // 20 log10(peak / max |w| farther than lambda/2 from the focus).
    double contrast_db = 0;
    double contrast_change_db = 0;      // worst |contrast - reference contrast| over foci
    double wall_s = 0;                  // calibrate() wall time
    double simulate_s = 0, search_s = 0, verify_s = 0;  // its stages (pipeline::StageTimes)
    double peak_rss_mb = 0;             // peak resident memory during calibrate()
};

struct StudyResult {
    std::string scene_file, scene_name;
    double f_max_hz = 0;
    double lambda_f_max_m = 0;
    CostModel cost;  // of the scene's own setting
    std::vector<StudyRow> rows;
};

using StudyProgress = std::function<void(const std::string &)>;
StudyResult run_accuracy_study(const std::string &scene_path, const StudyOptions &options,
                               const StudyProgress &progress = {});

// DIR/accuracy.csv, DIR/accuracy.svg, DIR/accuracy.png, DIR/accuracy.md;
// returns the markdown (also printed by the command).
std::string write_study_report(const StudyResult &r, const std::string &dir);

// Peak resident memory (MB) since the last reset_peak_rss() (Linux VmHWM;
// the reset first returns freed heap to the system with malloc_trim).
void reset_peak_rss();
double current_peak_rss_mb();

}  // namespace calib::study
