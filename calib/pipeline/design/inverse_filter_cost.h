// What a scene's inverse-filter designs cost, priced before any simulation
// (the dry run and the refusals, model/cost_model.h).
#pragma once
#include "pipeline/design/inverse_filter.h"

#include <cstddef>

namespace calib::pipeline {

struct InverseFilterShape {
    std::size_t channels = 0;      // C
    std::size_t samples = 0;       // S, of H's responses
    std::size_t drive_samples = 0; // J
    std::size_t points = 0;        // served by the shared designs: the lattice in the active area, the foci
    std::size_t plates = 1;        // the nominal plate and a robust design's members
    double rate_hz = 0;            // H's
};
// The scene's shape for H of `samples` at `rate_hz` on `lattice` (plates:
// the nominal one and the robust members, if any).
InverseFilterShape inverse_filter_shape(const CalibrationInput &in, double rate_hz, std::size_t samples,
                                        const ObservationLattice &lattice);
// Bytes the shared designs hold (each point's correlations, each plate's
// playback spectra), plus those of `running` designs at once (block
// Levinson's factor, the minimax passes' fields).
double inverse_filter_bytes(const InverseFilterShape &s, std::size_t running);
struct InverseFilterSeconds {
    double shared_s = 0;    // the correlations of every point, once (on one core)
    double per_focus_s = 0; // one focus's minimax design (on one core)
};
// Timed now, on one core: the shared designs' code on random responses of
// the shape's C, S and J at two point counts, extrapolated linearly in the
// points (block Levinson does not grow with them; the weighted sums and the
// playback do). Well under a second.
InverseFilterSeconds time_inverse_filter(const InverseFilterShape &s, const InverseFilterOptions &o);

} // namespace calib::pipeline
