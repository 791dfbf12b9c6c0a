// What a calibration will run, decided before anything runs: the candidate
// sites, the emitters (foci and probe points), the rate of the stored
// recordings, and every simulation with its length. `calibrate()` executes
// this plan; the cost model (model/cost_model.h) prices it, so the two cannot
// drift apart.
#pragma once
#include "pipeline/data/geometry.h"
#include "pipeline/data/input.h"

#include <cstddef>
#include <vector>

namespace calib::pipeline {

// One forward (verification) pass over every focus: the exciters play the
// focus's signals and the foci are recorded.
struct VerificationPass {
    // The pass that measures each focus's peak at full scale, from which the
    // stored level follows (linearity); the other pass verifies the stored signals.
    bool sets_level = false;
    // Per focus, a re-run to its focus instant for the |w| field there.
    bool snapshots = false;
};

struct CalibrationPlan {
    Band band;
    double lambda_centre_m = 0; // Kirchhoff A0 wavelength at the pulse centre
    double site_spacing_m = 0;  // candidate lattice (0 for placement = "fixed")
    std::vector<Point> sites;   // candidate exciter sites; placement = "fixed": the given positions
    // One reciprocity simulation per emitter: the foci of the placement
    // subset (placement/focus_subset.h), then the probe points.
    std::vector<Point> emitters;
    std::size_t foci = 0;                  // emitters that are foci: focus_subset.size()
    std::vector<std::size_t> focus_subset; // indices into the scene's foci, ascending
    double subset_cover_m = 0;             // every focus lies this close to a subset member
    std::size_t placement_focus_cap = 0;   // the cap the subset was chosen under
    double search_rate_hz = 0;             // rate of the stored (decimated) recordings

    // The simulations, each on one core (the foci run in parallel).
    std::size_t nodes = 0;        // grid nodes of the plate
    double time_step_s = 0;       // Kirchhoff step of the scene's settings (the thick plate's is smaller)
    std::size_t window_steps = 0; // per reciprocity simulation: the impulse response's window
    // How a reciprocity simulation records (placement/site_recording.h): a copy of the
    // field every site_decimation-th step; site_steps = the window and the
    // band-limited impulse's delay.
    std::size_t site_decimation = 1;
    std::size_t site_steps = 0;
    std::size_t drive_steps = 0; // per verification run: the kept part of the window and the tail
    // The forward passes ([effects.finger] only: the finger changes the plate
    // per touch position); empty when the transfer matrix serves.
    std::vector<VerificationPass> verification;
    // The transfer matrix (transfer/transfer.h): one simulation per exciter of
    // transfer_steps, and H's bytes (channels x observed points x samples,
    // float); the playback keeps their spectra too (about twice as much).
    bool transfer = true;
    std::size_t transfer_steps = 0;
    double transfer_bytes = 0;

    std::size_t probes() const { return emitters.size() - foci; }
};

// Throws std::invalid_argument (one line naming the scene key) when the
// candidate lattice is too large to enumerate (see max_candidate_sites).
CalibrationPlan plan(const CalibrationInput &in);

// Lattice points candidate_sites() visits for this band and spacing, counted
// without visiting them.
double lattice_points(const Band &band, double spacing_m);
// More lattice points than this are not enumerated: a placement search over
// them would not finish, and their recordings would not fit in memory.
constexpr double max_candidate_sites = 1e7;

} // namespace calib::pipeline
