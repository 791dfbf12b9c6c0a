// The plate *engine*: state and time stepping for one PlateOperator. The
// state is the displacement u^n and the increment d^n = u^n - u^{n-1}
// (leapfrog in increment form, plate_kernels.h). The bulk update is a
// compiled kernel, chosen per step between the lossless and the lossy
// variant; the rows near the edges are sparse rows of the factored operator;
// sources, receivers and effect extensions act on a few nodes after that.
#pragma once

#include "engine/plate_kernels.h"
#include "engine/plate_operator.h"
#include "engine/point_field.h"

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace calib::engine {

struct EngineOptions {
    int threads = 0;                           // 0: OpenMP's default
    std::size_t parallel_min_cells = 1u << 16; // smaller interiors run on one thread (fork/join costs more)
    bool skip_stability_check = false;         // tests only: lets a test show the bound is real
    bool edge_band_always = false;             // tests and benchmarks: sparse edge rows even where ghosts would do
};

// Sets flush-to-zero and denormals-are-zero on this thread and on OpenMP's
// worker threads for its lifetime (float runs: decaying fields would
// otherwise reach denormals and slow down 10-100x).
class ScopedFlushDenormals {
  public:
    ScopedFlushDenormals();
    ~ScopedFlushDenormals();
    ScopedFlushDenormals(const ScopedFlushDenormals &) = delete;
    ScopedFlushDenormals &operator=(const ScopedFlushDenormals &) = delete;

  private:
    unsigned saved_ = 0;
};

// Flush-to-zero and denormals-are-zero on this thread only. A single-threaded
// run needs no more; ScopedFlushDenormals also forks an OpenMP team to set
// the workers' flags, and that fork/join per run() call cost 25 ms on a
// loaded 2-core machine (run(500) on a 40 x 30 grid: 56 instead of 2.3 us per
// step; docs/engine.md, "Stability suite").
class ThreadFlushDenormals {
  public:
    ThreadFlushDenormals();
    ~ThreadFlushDenormals();
    ThreadFlushDenormals(const ThreadFlushDenormals &) = delete;
    ThreadFlushDenormals &operator=(const ThreadFlushDenormals &) = delete;

  private:
    unsigned saved_ = 0;
};

// The ghost mirrors of a plate's clamped and supported edges (+1 clamped,
// -1 supported; plate_kernels.h), for PlateEngine and the lanes; off where
// the operator has a free edge.
template <typename T>
GhostMirrors<T> ghost_mirrors_of(const PlateOperator &op)
{
    if (!op.mirror_edges())
        return {};
    const Edges &e = op.params().edges;
    auto sign = [](EdgeKind k) { return k == EdgeKind::clamped ? T(1) : T(-1); };
    return {true, op.grid().nx, op.grid().ny, sign(e.left), sign(e.right), sign(e.bottom), sign(e.top)};
}

// An effect with a state of its own (finger, exciter model; engine/effects/)
// acts after the bulk, edge and source update on a few nodes, through the
// point interface (point_field.h): it reads W from the new field u^{n+1} and
// the increments d^{n+1} = u^{n+1} - u^n and d^n, and adds to u^{n+1}
// (add_displacement(), which keeps d^{n+1} consistent). An engine without
// extensions never calls a hook.
template <typename T>
class PlateEngine final : public PointField {
  public:
    // Throws std::invalid_argument if the time step is not below the operator's
    // stability bound (unless options.skip_stability_check).
    PlateEngine(std::shared_ptr<const PlateOperator> op, double time_step_s, const EngineOptions &options = {});
    ~PlateEngine();
    PlateEngine(const PlateEngine &) = delete;
    PlateEngine &operator=(const PlateEngine &) = delete;

    const PlateOperator &plate() const { return *op_; }
    double time_step() const override { return k_; }
    std::size_t steps_done() const { return steps_; }
    // Whether step() runs its bulk update on an OpenMP team.
    bool threaded() const { return bulk_threads_ > 1; }
    // Whether the edges are ghost mirrors (clamped and supported edges) rather
    // than an edge band of sparse rows (any free edge).
    bool mirror_edges() const { return mirror_edges_; }

    // Point force (N) with bilinear spreading; the receiver reads the
    // displacement with the same weights, which makes A->B equal B->A.
    std::size_t add_source(double x_m, double y_m);
    std::size_t add_receiver(double x_m, double y_m);
    // Force applied during the next step (held constant over that step).
    void set_source_force(std::size_t source, double force_n) { sources_[source].force = T(force_n); }
    // Displacement (m) at a receiver for the current time level.
    double receiver_value(std::size_t receiver) const;

    void add_extension(std::unique_ptr<PointExtension> ext) { extensions_.push_back(std::move(ext)); }

    // The point interface of the extensions (point_field.h).
    double lambda_max() const override { return op_->lambda_max_stiffness(); }
    PointTaps couple(double x_m, double y_m, const char *effect) const override;
    PointLevels read(const PointTaps &point) const override;
    void apply(const PointTaps &point, double force_n) override;

    // One step: u^{n+1} and d^{n+1} from u^n and d^n.
    void step();
    // Whether step_block() may run: ghost mirrors, no extension, rows enough
    // for the threads (block_threads_fit).
    bool can_block() const
    {
        return mirror_edges_ && extensions_.empty() && rigid_count_ == 0 && block_threads_fit(1, ny_, bulk_threads_);
    }
    // `steps` (2 .. bulk_max_block_steps) steps in one sweep
    // (bulk_update_block, on the engine's threads): all but the last with no
    // source force, the last with the forces set now (as step() `steps` times
    // with every force 0 before the last); between[(m - 1) * receivers + r]
    // receives receiver_value(r) of the level after step m (1 .. steps - 1).
    // `blocks` > 1: that many such sweeps in a row in one parallel region
    // (one barrier between them), every force 0 but in the last step of the
    // last; m then runs 1 .. blocks steps - 1. scan_after (one per block):
    // the whole-field scan of the level after a block runs on the team inside
    // the region (BlockScan); the first that sees a non-finite value ends the
    // sweeps there, and non_finite_report() then reports it. Returns the
    // blocks run (`blocks` but after such a scan).
    int step_block(int steps, double *between, int blocks = 1, const std::uint8_t *scan_after = nullptr);

    // Discrete energy (J) at time n+1/2 from the two newest levels; exactly
    // conserved without loss and sources, non-increasing with loss.
    double energy() const;

    // Fields on the node grid, row-major (j, i), (ny+1) x (nx+1), metres.
    std::vector<double> displacement() const;
    // Empty while every node of the newest level is finite; else what and
    // where: the first non-finite node in row order, their count and extent.
    // Free after a step_block whose last block's scan found the level clean.
    std::string non_finite_report() const;
    double w_at(int i, int j) const { return double(u_[j * stride_ + i]); } // the newest level at node (i, j)
    // Sets u^n and u^{n-1} (values at fixed nodes are ignored).
    void set_state(const std::vector<double> &current, const std::vector<double> &previous);

    using value_type = T;
    // For extensions and checks: node (i, j) of a level is at
    // field[j * stride() + i]; force_gain(node) turns a force (N) at a node
    // into its displacement increment this step.
    std::ptrdiff_t stride() const { return stride_; }
    double force_gain(std::size_t node) const;
    // Adds a displacement (m) to u^{n+1} at a field offset, and to d^{n+1}
    // (and the momentum it carries to the rigid-body bookkeeping).
    void add_displacement(std::ptrdiff_t offset, T delta_m);

  private:
    // Edge-band rows in factored form (plate_operator.h): first the strains
    // (integer-weighted differences of the field: of u for K, of d for Gm),
    // then each row as a combination of strains. A free plate's rigid motion has zero strains,
    // so it feels no force in float either, whatever the rounding of `coef`.
    // The band sums in double (a row has up to ~20 terms; the band is a thin
    // fraction of the grid), so its round-off is one rounding per node and
    // step, as in the bulk.
    // Stored in SIMD blocks (plate_engine_edge.cpp, edge_kernels.h).
    static constexpr int max_strain_nodes = 4; // PlateOperator::Stencil
    struct StrainSet {
        // blocks[L-1] blocks of strains of L nodes, [block][node][lane].
        std::array<std::size_t, max_strain_nodes> blocks{};
        std::vector<std::int32_t> offset;
        std::vector<T> weight;     // small integers, exact in T; 0 in a padded lane
        std::vector<double> value; // scratch, one per (padded) strain
    };
    struct RowTerms { // [block][term][lane], group after group
        std::vector<std::uint32_t> strain;
        std::vector<T> coef;
    };
    struct RowGroup { // consecutive blocks of rows with the same term counts
        std::uint32_t blocks = 0, r_terms = 0, s_terms = 0;
    };
    struct BandRow {
        std::uint32_t slot; // in band_next_
        std::ptrdiff_t target;
    };
    struct PointTap {
        std::vector<std::ptrdiff_t> offset;
        std::vector<T> weight; // sources: displacement per newton; receivers: interpolation weight
        T force = 0;
    };
    template <bool Lossy>
    void step_impl();
    void apply_sources();
    // The receivers step_block reads between its steps: those read once row
    // j is updated (the last row each reads) are receiver[first[j] ..
    // first[j + 1]). Rebuilt when a receiver is added.
    struct BlockReads {
        std::vector<std::uint32_t> first, receiver;
        std::vector<std::uint8_t> rows; // 1 where a receiver's last row is (the kernel's hook_rows)
    };
    BlockReads block_reads_;
    // receiver_value with the rows under a block's own read from its copy.
    double receiver_value(std::size_t receiver, const BlockBelow &below) const;
    bool block_reads_stale_ = true;
    std::vector<std::pair<int, int>> receiver_rows_; // the first and last row each receiver reads
    void build_block_reads();
    // Clamped and supported edges only: ghost nodes instead of an edge band.
    bool mirror_edges_apply() const;
    void refresh_stale_ghosts(); // a whole pass if something outside the sweep moved a node next to an edge
    // Rigid-body momenta (free plates): see build_rigid_modes().
    void build_rigid_modes();
    std::array<double, 3> raw_moments() const;
    void restore_rigid_momenta();
    std::ptrdiff_t offset_of(std::size_t node) const;
    void build_edge_rows();
    template <bool Lossy>
    void edge_band_update(); // band_next_ from u^n and d^n

    std::shared_ptr<const PlateOperator> op_;
    EngineOptions options_;
    double k_ = 0;
    bool lossy_ = false;
    int nx_ = 0, ny_ = 0;
    std::ptrdiff_t stride_ = 0;
    std::size_t steps_ = 0;
    // steps_ when step_block's scan last found the newest level finite and
    // nothing changed it since (no_scan: none).
    static constexpr std::size_t no_scan = std::size_t(-1);
    std::size_t scanned_clean_ = no_scan;
    int bulk_threads_ = 1;
    // step_block's cut of the rows over the team (BlockTeam; empty on one
    // thread), each thread's busy time in the last call and since the last
    // balance_seams, and the blocks since.
    static constexpr std::size_t balance_blocks = 16;
    std::vector<int> seams_;
    std::vector<double> busy_, busy_sum_;
    std::size_t busy_blocks_ = 0;
    bool mirror_edges_ = false;
    bool ghosts_stale_ = true; // the ghosts of u^n need a pass before the next sweep
    T *storage_ = nullptr;
    T *u_ = nullptr, *inc_ = nullptr, *inc_before_ = nullptr; // u^n, d^n, d^{n-1} (before a step)
    T *scratch_ = nullptr; // the bulk kernel's rows, bulk_threads_ * bulk_scratch_rows
    BulkCoefficients<T> bulk_{};
    // d+ = g d - R u - S d on the edge band: strains of u and rows of R, strains of d and rows of S.
    StrainSet strains_r_, strains_s_;
    RowTerms terms_r_, terms_s_;
    std::vector<RowGroup> row_groups_;
    std::vector<std::int32_t> band_target_; // field offset of each (padded) row
    std::vector<BandRow> band_rows_;        // the real rows
    std::vector<double> band_next_;         // d^{n+1} of the (padded) band, held while the bulk reads d^n
    // Rigid-body modes r_c = R b_c (R: the fields 1, i, j on the unknowns) that
    // K (and Gm, with sigma1 loss) annihilate; the momenta p_c = r_c^T M d the
    // scheme conserves exactly (times g per step with sigma0), what sources
    // and extensions add, and the M-Gram matrix of the modes, inverted.
    int rigid_count_ = 0;
    std::array<std::array<double, 3>, 3> rigid_b_{};
    std::array<double, 3> rigid_expected_{};
    std::array<std::array<double, 3>, 3> rigid_gram_inv_{};
    std::vector<PointTap> sources_, receivers_;
    std::vector<std::unique_ptr<PointExtension>> extensions_;
};

extern template class PlateEngine<float>;
extern template class PlateEngine<double>;

} // namespace calib::engine
