// The calibration pipeline: per-focus simulation by reciprocity, placement
// search, time-reversal signals, verification by forward simulation.
// `calibgen calibrate` and `calibgen verify` are thin shells around this.
#pragma once
#include "engine/effects/effects.h"
#include "engine/plate_operator.h"
#include "engine/simulation.h"
#include "pipeline/spec.h"
#include "pipeline/time_reversal.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace calib::pipeline {

struct CalibrationInput {
    std::string scene_name;
    std::string scene_hash;  // "crc32:..." of the scene file bytes
    std::shared_ptr<const engine::PlateOperator> plate;
    engine::SimulationOptions simulation;
    ActiveAreaSpec active;
    ExcitersSpec exciters;
    FociSpec foci;
    PulseSpec pulse;
    CalibrationSpec calibration;
    engine::effects::EffectsSpec effects;  // [effects]; the exciter model acts here (docs/effects.md)
};

// Progress of long stages (stage name, items done, items total).
using ProgressFn = std::function<void(const std::string &stage, size_t done, size_t total)>;

struct PlacementReport {
    Band band;
    std::vector<Point> sites;         // candidate sites
    std::vector<size_t> chosen;       // indices into sites
    std::vector<size_t> regular;      // the regular symmetric pattern
    double chosen_contrast_db = 0, regular_contrast_db = 0;  // predicted (reciprocity)
    double chosen_variety = 0, regular_variety = 0;          // the seed's criterion
    unsigned evaluations = 0;
    std::vector<size_t> probe_rows;   // extra points the contrast was checked at (none when K >= 4)
};

struct FocusMetrics {
    uint32_t id = 0;
    Point at;
    double peak_m = 0;              // max |w| at the focus when its signals play at full scale
    double peak_time_s = 0;
    double max_other_foci_m = 0;    // max |w| at every other focus, at all times
    double contrast_db = 0;         // 20 log10(peak / max_other)
    double spot_diameter_m = 0;     // circle of the area around the focus where |w| >= peak / 2
    // At the focus instant: the largest |w| on the plate farther than lambda/2
    // from the focus, and the focus's margin over it (what the seed's Fig. 4 shows).
    double max_elsewhere_m = 0;
    double field_contrast_db = 0;
    double lambda_half_m = 0;       // half the A0 wavelength at the pulse centre
    bool crosses_threshold = false;
    bool others_below_threshold = false;
};

struct Verification {
    std::vector<FocusMetrics> foci;
    double trace_rate_hz = 0;
    // traces[f][g]: displacement at focus g while focus f is driven (m).
    std::vector<std::vector<std::vector<double>>> traces;
    // snapshots[f]: |w| field (node grid, row-major) at focus f's peak.
    std::vector<std::vector<float>> snapshots;
    int grid_nx = 0, grid_ny = 0;
    double grid_h_m = 0;
};

struct StageTimes {
    double simulation_s = 0, search_s = 0, signals_s = 0, verification_s = 0;
};

struct CalibrationResult {
    std::vector<Point> exciters;
    std::vector<DriveSignals> signals;  // per focus, in scene order
    std::vector<double> full_scale_peak_m;  // focal peak if played at full scale, per focus
    PlacementReport placement;
    Verification verification;
    StageTimes times;
    double search_rate_hz = 0;          // rate of the stored (decimated) recordings
};

// Refuses impossible scenes before any simulation (std::invalid_argument,
// one line naming the scene key): foci off the plate, no room for the
// exciters, a window shorter than one crossing of the plate.
void check_feasible(const CalibrationInput &in);

CalibrationResult calibrate(const CalibrationInput &in, const ProgressFn &progress = {});

// Forward simulation: drive the exciters with per-focus signals ([n][c]
// int16 at rate_hz, full scale = force_full_scale_n) and measure every focus.
// Without snapshots only the traces and peaks are measured (half the cost).
Verification verify_signals(const CalibrationInput &in, const std::vector<Point> &exciters,
                            const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                            const ProgressFn &progress = {}, bool snapshots = true);

// Forward simulation of one multichannel drive (e.g. what the device
// played): returns traces[0][g] and, per focus, the peak and its time.
Verification verify_drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                          const std::vector<float> &frames, unsigned channels, double rate_hz,
                          const ProgressFn &progress = {});

// Writes the table atomically with common/ (scale_m from the verification).
void write_table(const std::string &path, const CalibrationInput &in, const CalibrationResult &result);

// A0 wavelength (Kirchhoff) at frequency f on the scene's plate.
double a0_wavelength_m(const engine::PlateOperator &plate, double f_hz);

// CRC-32 (zlib) of the scene file bytes, as "crc32:<8 hex>": identifies the
// scene a table came from (provenance, not security).
std::string scene_hash(const std::string &bytes);

}  // namespace calib::pipeline
