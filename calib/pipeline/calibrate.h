// The calibration pipeline, in stages: responses (one reciprocity simulation
// per focus of the placement subset), placement search, the transfer matrix H
// of the placed exciters (transfer.h), time-reversal signals from H, level and
// verification by convolution with H (verification.cpp). A scene with
// [effects.finger] verifies by forward simulation per focus instead: the
// finger changes the plate at each touch position, so H does not hold.
// `calibgen calibrate` and `calibgen verify` are thin shells around this.
#pragma once
#include "engine/effects/effects.h"
#include "engine/plate_operator.h"
#include "engine/simulation.h"
#include "pipeline/spec.h"
#include "pipeline/time_reversal.h"
#include "pipeline/tolerance_spec.h"

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
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
    std::optional<ToleranceSpec> tolerance;  // [tolerance]: verify over the box (docs/robustness.md)
    std::optional<RobustSpec> robust;        // [calibration] robust: design over an ensemble
    // The radius beyond which a focus's surroundings are judged (the whole
    // area, the other foci, the control points): lambda/2 at the pulse
    // centre on the scene's plate (0: from `plate`). A perturbed plate
    // (tolerance.h) keeps its scene's, so every plate of a tolerance box is
    // held to the same area in millimetres: a panel whose waves are 0.75 %
    // slower is not judged 0.6 mm closer to the focus.
    double lambda_half_m = 0;
    double plate_temperature_c = 23;  // [plate] temperature_c: the table's panel section
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
    // The foci the search weighed (focus_subset.h): indices into the scene's
    // foci, every focus within subset_cover_m of one of them; one simulation
    // per member and probe point.
    std::vector<size_t> focus_subset;
    double subset_cover_m = 0;
    size_t simulations = 0;
    // The placements judged by the verdict (placement_verdict.h), in the
    // order judged: the proxy's choice, the regular pattern, each refinement.
    struct Judged {
        std::vector<size_t> chosen;      // indices into sites
        size_t passing = 0;              // foci passing the verdict (of the scene's)
        size_t passing_at_target = 0;    // ... with the focal peak at the scene's amplitude
        double worst_whole_area_db = 0;  // least whole-area contrast over the foci
        double proxy_db = 0;             // the contrast model's worst focus, foci only (the first search's)
        size_t probes = 0;               // ghost probes the search had seen when it proposed this one
        bool regular = false;
    };
    std::vector<Judged> judged;
    std::vector<Point> ghost_probes;     // the ghosts added as probe rows, in order
    size_t probe_simulations = 0;
    // Pairs of judged placements the proxy (foci only) ranked as the verdict did.
    size_t proxy_agreements = 0, proxy_pairs = 0;
    double verdict_s = 0;                // the time the judging took (transfers, signals, verification)
};

struct FocusMetrics {
    uint32_t id = 0;
    Point at;
    double peak_m = 0;              // max |w| at the focus while its stored signals play
    double peak_time_s = 0;         // from the start of playback
    double lead_time_s = 0;         // playback start to the focal peak (what a person waits, before device latency)
    double max_other_foci_m = 0;    // max |w| at every other focus farther than lambda/2, at all times
    double other_foci_contrast_db = 0;  // 20 log10(peak / max_other)
    double spot_diameter_m = 0;     // circle of the area around the focus where |w| >= peak / 2
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
    double lambda_half_m = 0;       // half the A0 wavelength at the pulse centre
    bool crosses_threshold = false;
    bool others_below_threshold = false;
    bool whole_area_below_threshold = false;  // nowhere beyond lambda/2 reaches the threshold
    bool whole_area = false;        // the whole-area figures were measured
    // The stored signals' sound on axis 0.5 m above the plate centre (baffled
    // plate, pipeline/radiation.h): A-weighted exposure level L_AE (dB re
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
    double worst_margin_db = 0;  // foci[worst].margin_db()
    bool all_pass() const { return passing == total; }
};
VerdictSummary summarize_verdict(const std::vector<FocusMetrics> &foci);

struct Verification {
    std::vector<FocusMetrics> foci;
    double trace_rate_hz = 0;
    // traces[f][g]: displacement at focus g while focus f is driven (m).
    std::vector<std::vector<std::vector<double>>> traces;
    // snapshots[f]: |w| field at focus f's peak on the grid below (row-major):
    // the observation lattice of H, or the plate grid on the forward path.
    std::vector<std::vector<float>> snapshots;
    int grid_nx = 0, grid_ny = 0;   // intervals per axis (points - 1)
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

struct StageTimes {
    double simulation_s = 0, search_s = 0, transfer_s = 0, signals_s = 0, verification_s = 0;
    double sound_s = 0;  // the radiated sound of every focus (part of verification_s)
    // The search by the verdict (placement_verdict.h): every placement judged,
    // the probes and the searches again; the chosen placement's transfer,
    // signals and verification are in the figures above too.
    double verdict_s = 0;
};

// Sizes of the transfer matrix a calibration used.
struct TransferSummary {
    std::size_t channels = 0, lattice_points = 0, exact_points = 0, samples = 0;
    double rate_hz = 0, lattice_spacing_m = 0, bytes = 0;
};

struct CalibrationResult {
    std::vector<Point> exciters;
    std::vector<DriveSignals> signals;  // per focus, in scene order
    std::vector<double> full_scale_peak_m;  // focal peak if played at full scale, per focus
    PlacementReport placement;
    Verification verification;
    StageTimes times;
    double search_rate_hz = 0;          // rate of the stored (decimated) recordings
    TransferSummary transfer;           // empty on the forward path ([effects.finger])
    std::optional<ToleranceReport> tolerance;  // with [tolerance] or a robust design (pipeline/robust.h)
};

// Refuses impossible scenes before any simulation (std::invalid_argument,
// one line naming the scene key): foci off the plate, no room for the
// exciters, a window shorter than one crossing of the plate.
void check_feasible(const CalibrationInput &in);

CalibrationResult calibrate(const CalibrationInput &in, const ProgressFn &progress = {});

// Drive the exciters with per-focus signals ([n][c] int16 at rate_hz, full
// scale = force_full_scale_n) and measure every focus: by convolution with the
// transfer matrix of these exciters (simulated here, one simulation per
// exciter), or, with [effects.finger], by a forward simulation per focus.
// Without `whole_area` only the foci are measured (traces, peaks, contrast
// over the other foci).
Verification verify_signals(const CalibrationInput &in, const std::vector<Point> &exciters,
                            const std::vector<std::vector<int16_t>> &signals, double rate_hz,
                            const ProgressFn &progress = {}, bool whole_area = true);

// One multichannel drive (e.g. what the device played, or a superposition of
// foci): returns traces[0][g] and, per focus, the peak and its time; by
// convolution with H (or forward simulation with [effects.finger]).
Verification verify_drive(const CalibrationInput &in, const std::vector<Point> &exciters,
                          const std::vector<float> &frames, unsigned channels, double rate_hz,
                          const ProgressFn &progress = {});

// Whether a scene's plate is linear and time-invariant during playback (H
// holds): every effect but the finger.
bool transfer_holds(const CalibrationInput &in);

// The options of every simulation of a calibration: one core each (they run
// in parallel), the Mindlin engine when the scene asks for the thick plate.
engine::SimulationOptions single_core_options(const CalibrationInput &in);

// Writes the table atomically with common/ (scale_m from the verification).
void write_table(const std::string &path, const CalibrationInput &in, const CalibrationResult &result);

// A0 wavelength (Kirchhoff) at frequency f on the scene's plate.
double a0_wavelength_m(const engine::PlateOperator &plate, double f_hz);
// The judged radius: in.lambda_half_m, or lambda/2 at the pulse centre on in.plate.
double judged_lambda_half_m(const CalibrationInput &in);

// CRC-32 (zlib) of the scene file bytes, as "crc32:<8 hex>": identifies the
// scene a table came from (provenance, not security).
std::string scene_hash(const std::string &bytes);

}  // namespace calib::pipeline
