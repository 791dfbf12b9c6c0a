// Several simulations of one plate stepped together: each source's field in a
// lane of its own, the lanes of a node side by side in memory (node (i, j),
// lane l at [j][i][l]), so one sweep of the bulk kernel updates them all with
// full vectors and the per-step work (ghosts, sources, reads) is shared. The
// pipeline's simulations are of this kind: the placement's foci and probe
// points, the transfer matrix's exciters, each one point source with the
// same signal, all read at the same points and steps.
//
// Per lane the arithmetic is PlateEngine's, term for term (plate_kernels.h,
// bulk_update_lanes): a lane's record equals a Simulation's of the same
// source (test Lanes.EachLaneIsItsOwnSimulation). Clamped and simply
// supported edges only (the ghost mirrors of PlateEngine); a free edge's band,
// the thick plate and the effects stay with Simulation (lanes_apply()).
//
// The sources are shared out into batches of 1, 2, 4 or 8 lanes over the
// OpenMP threads, a batch per thread at a time (lane_batches()).
#pragma once

#include "engine/plate_operator.h"
#include "engine/simulation.h"

#include <cstddef>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::engine {

struct LanesRequest {
    struct Source {
        double x_m = 0, y_m = 0;
    };
    std::vector<Source> sources; // one lane each
    // The force (N) of every source in step n, n from 0; zero after it ends.
    std::vector<double> force_n;
    // Read after steps first_step, first_step + interval, ... (`samples` of them):
    // the receivers (bilinear, as Simulation's) and, with lattice_stride > 0,
    // w at every lattice_stride-th node of both axes from node (0, 0).
    std::vector<Source> receivers;
    int lattice_stride = 0;
    std::size_t first_step = 0, interval = 1, samples = 0;
    // Tests and benchmarks: batches of this many lanes (1, 2, 4 or 8), one
    // thread; 0: lane_batches() over the options' threads.
    int width = 0;
};

struct LaneRecord {
    std::vector<std::vector<double>> traces; // [receiver][sample]
    std::vector<float> lattice;              // [sample][lattice point], row-major points
};

// A source whose field stopped being finite: which one, and what Simulation
// would have said (step, time, node).
class SourceFailure : public std::runtime_error {
  public:
    SourceFailure(std::size_t source, const std::string &what) : std::runtime_error(what), source_(source) {}
    std::size_t source() const { return source_; }

  private:
    std::size_t source_;
};

// Whether these options run on lanes: the Kirchhoff engine with mirrored
// edges (no free edge), no thick plate.
bool lanes_apply(const PlateOperator &op, const SimulationOptions &options);

// The batches `count` sources are shared into over `threads` threads: each
// an engine of `width` lanes (1, 2, 4 or 8) carrying `lanes` of the sources,
// widest first.
struct LaneBatch {
    int lanes = 0, width = 0;
};
std::vector<LaneBatch> lane_batches(std::size_t count, int threads);

// Runs every source of the request; progress(0, total) first, then
// progress(done, total) after each batch.
// Throws SourceFailure on a non-finite field or force, std::invalid_argument
// for options lanes_apply() refuses.
std::vector<LaneRecord> simulate_lanes(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options,
                                       const LanesRequest &request,
                                       const std::function<void(std::size_t, std::size_t)> &progress = {});

} // namespace calib::engine
