// What a calibration returns: the placement and how it was found, the
// drives of every focus, their verification, the times of the stages, the
// sizes of the transfer matrix, and the table over the tolerance box.
#pragma once
#include "pipeline/data/drive_signals.h"
#include "pipeline/data/geometry.h"
#include "pipeline/data/tolerance_spec.h"
#include "pipeline/data/transfer_matrix.h"
#include "pipeline/data/verdict.h"

#include <cstddef>
#include <optional>
#include <vector>

namespace calib::pipeline {

struct PlacementReport {
    Band band;
    std::vector<Point> sites;                               // candidate sites
    std::vector<size_t> chosen;                             // indices into sites
    std::vector<size_t> regular;                            // the regular symmetric pattern
    double chosen_contrast_db = 0, regular_contrast_db = 0; // predicted (reciprocity)
    double chosen_variety = 0, regular_variety = 0;         // the seed's criterion
    unsigned evaluations = 0;
    std::vector<size_t> probe_rows; // extra points the contrast was checked at (none when K >= 4)
    // The foci the search weighed (placement/focus_subset.h): indices into the scene's
    // foci, every focus within subset_cover_m of one of them; one simulation
    // per member and probe point.
    std::vector<size_t> focus_subset;
    double subset_cover_m = 0;
    size_t simulations = 0;
    // The placements judged by the verdict (pipeline/placement_verdict.h), in the
    // order judged: the proxy's choice, the regular pattern, each refinement.
    struct Judged {
        std::vector<size_t> chosen;     // indices into sites
        size_t passing = 0;             // foci passing the verdict (of the scene's)
        size_t passing_at_target = 0;   // ... with the focal peak at the scene's amplitude
        double worst_whole_area_db = 0; // least whole-area contrast over the foci
        double proxy_db = 0;            // the contrast model's worst focus, foci only (the first search's)
        size_t probes = 0;              // ghost probes the search had seen when it proposed this one
        bool regular = false;
    };
    std::vector<Judged> judged;
    std::vector<Point> ghost_probes; // the ghosts added as probe rows, in order
    size_t probe_simulations = 0;
    // Pairs of judged placements the proxy (foci only) ranked as the verdict did.
    size_t proxy_agreements = 0, proxy_pairs = 0;
    double verdict_s = 0; // the time the judging took (transfers, signals, verification)
};

struct StageTimes {
    double simulation_s = 0, search_s = 0, transfer_s = 0, signals_s = 0, verification_s = 0;
    // The site recordings resampled to the search rate and convolved with the
    // pulse (part of simulation_s; the rest is the engine's simulations).
    double site_responses_s = 0;
    double sound_s = 0; // the radiated sound of every focus (part of verification_s)
    // The search by the verdict (pipeline/placement_verdict.h): every placement judged,
    // the probes and the searches again; the chosen placement's transfer,
    // signals and verification are in the figures above too.
    double verdict_s = 0;
};

// Sizes of the transfer matrix a calibration used.
struct TransferSummary {
    std::size_t channels = 0, lattice_points = 0, exact_points = 0, samples = 0;
    double rate_hz = 0, lattice_spacing_m = 0, bytes = 0;
};
inline TransferSummary transfer_summary(const TransferMatrix &H)
{
    return {H.channels,          H.lattice.size(), H.point_count() - H.lattice.size(), H.samples, H.rate_hz,
            H.lattice.spacing_m, H.bytes()};
}

struct CalibrationResult {
    std::vector<Point> exciters;
    std::vector<DriveSignals> signals;     // per focus, in scene order
    std::vector<double> full_scale_peak_m; // focal peak if played at full scale, per focus
    PlacementReport placement;
    Verification verification;
    StageTimes times;
    double search_rate_hz = 0;                // rate of the stored (decimated) recordings
    TransferSummary transfer;                 // empty on the forward path ([effects.finger])
    std::optional<ToleranceReport> tolerance; // with [tolerance] or a robust design (robustness/tolerance_stage.h)
};

} // namespace calib::pipeline
