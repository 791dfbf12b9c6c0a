#include "engine/plate_engine.h"

#include <omp.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <map>
#include <new>
#include <stdexcept>
#include <tuple>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define HAPTIC_HAVE_MXCSR 1
#endif

namespace calib::engine {

ScopedFlushDenormals::ScopedFlushDenormals()
{
#ifdef HAPTIC_HAVE_MXCSR
    saved_ = _mm_getcsr();
    const unsigned ftz_daz = saved_ | 0x8040u;
    _mm_setcsr(ftz_daz);
#pragma omp parallel
    _mm_setcsr(ftz_daz);
#endif
}

ScopedFlushDenormals::~ScopedFlushDenormals()
{
#ifdef HAPTIC_HAVE_MXCSR
    const unsigned saved = saved_;
#pragma omp parallel
    _mm_setcsr(saved);
    _mm_setcsr(saved);
#endif
}

ThreadFlushDenormals::ThreadFlushDenormals()
{
#ifdef HAPTIC_HAVE_MXCSR
    saved_ = _mm_getcsr();
    _mm_setcsr(saved_ | 0x8040u);
#endif
}

ThreadFlushDenormals::~ThreadFlushDenormals()
{
#ifdef HAPTIC_HAVE_MXCSR
    _mm_setcsr(saved_);
#endif
}

template <typename T>
PlateEngine<T>::PlateEngine(std::shared_ptr<const PlateOperator> op, double time_step_s, const EngineOptions &options)
    : op_(std::move(op)), options_(options), k_(time_step_s)
{
    if (!op_)
        throw std::invalid_argument("PlateEngine: no operator");
    if (!options_.skip_stability_check)
        op_->check_time_step(k_);
    const Grid &g = op_->grid();
    nx_ = g.nx;
    ny_ = g.ny;
    mirror_edges_ = mirror_edges_apply();
    // The bulk kernel's first column (i = 1 with ghost mirrors, 2 beside an
    // edge band) starts a 64-byte line in every row, so its vectors of u, d
    // and the ring rows load whole lines (an unaligned 512-bit load spans
    // two; docs/engine.md, "Speed"); a row's storage
    // holds at least one node before i = 0 (the ghost at i = -1) and ends with
    // room for the ghost at i = nx + 1; a ghost row above and below.
    const std::ptrdiff_t per_line = std::ptrdiff_t(64 / sizeof(T));
    const std::ptrdiff_t shift = per_line - (mirror_edges_ ? 1 : 2); // node (0, j) within its row's storage
    stride_ = per_line + (std::ptrdiff_t(nx_ + 2) + per_line - 1) / per_line * per_line;
    // Not a multiple of 4 KiB: the stencil's five rows would share their L1
    // sets (and alias in the store buffer); on 997 x 997 that made a step 1.7x
    // slower.
    if (stride_ * std::ptrdiff_t(sizeof(T)) % 4096 == 0)
        stride_ += per_line;
    if (nx_ > 3 && ny_ > 3) {
        const std::size_t cells = std::size_t(nx_ - 3) * std::size_t(ny_ - 3);
        const int threads = options_.threads > 0 ? options_.threads : omp_get_max_threads();
        bulk_threads_ = cells >= options_.parallel_min_cells ? std::max(1, threads) : 1;
    }
    const std::size_t level = std::size_t(stride_) * std::size_t(ny_ + 3);
    const std::size_t scratch =
        std::size_t(stride_) * std::size_t(bulk_threads_ * std::max(bulk_scratch_rows, bulk_block_scratch_rows));
    const std::size_t total = 3 * level + scratch;
    storage_ = static_cast<T *>(std::aligned_alloc(64, total * sizeof(T)));
    if (!storage_)
        throw std::bad_alloc();
    std::memset(static_cast<void *>(storage_), 0, total * sizeof(T));
    const std::ptrdiff_t origin = stride_ + shift; // node (0, 0)
    u_ = storage_ + origin;
    inc_ = storage_ + level + origin;
    inc_before_ = storage_ + 2 * level + origin;
    scratch_ = storage_ + 3 * level + shift; // the kernel indexes its rows as the field's

    const Loss &loss = op_->params().loss;
    lossy_ = loss.active();
    const double h = g.h;
    const double mu2 = op_->kappa() * op_->kappa() * k_ * k_ / (h * h * h * h);
    const double nu1 = 2 * loss.sigma1 * k_ / (h * h);
    const double d = 1.0 / (1.0 + loss.sigma0 * k_);
    bulk_.g = T(d * (1 - loss.sigma0 * k_));
    bulk_.mu2 = T(d * mu2);
    bulk_.nu1 = T(d * nu1);
    if (mirror_edges_)
        bulk_.ghosts = ghost_mirrors_of<T>(*op_);
    else
        build_edge_rows();
    build_rigid_modes();
    if (bulk_threads_ > 1 && block_threads_fit(1, ny_, bulk_threads_)) {
        for (int t = 0; t <= bulk_threads_; ++t)
            seams_.push_back(block_seam(1, ny_, bulk_threads_, t));
        busy_.assign(std::size_t(bulk_threads_), 0.0);
        busy_sum_.assign(std::size_t(bulk_threads_), 0.0);
    }
}

// Clamped and simply supported edges (any mix, PlateOperator::mirror_edges()):
// the assembled rows next to them are the 13-point stencil with a ghost node
// mirrored across the edge (w_-1 = +w_1 clamped, -w_1 supported; the
// boundary nodes w_0 = 0), and the loss operator's the 5-point Laplacian with
// the boundary at zero, on a uniform mass (test
// EngineMirrorEdges.RowsNextToTheEdgeAreTheMirroredStencil). The bulk kernel
// then updates every unknown, after the ghosts are set from u^n: no edge band
// at all, which cost 0.7 x the bulk on Fig. 7's 81 x 81 grid (docs/engine.md,
// "Where a step's time goes").
template <typename T>
bool PlateEngine<T>::mirror_edges_apply() const
{
    return op_->mirror_edges() && !options_.edge_band_always && nx_ >= 4 && ny_ >= 4;
}

template <typename T>
void PlateEngine<T>::refresh_stale_ghosts()
{
    if (ghosts_stale_)
        mirror_ghosts(u_, stride_, bulk_.ghosts);
    ghosts_stale_ = false;
}

template <typename T>
PlateEngine<T>::~PlateEngine()
{
    std::free(storage_);
}

template <typename T>
std::ptrdiff_t PlateEngine<T>::offset_of(std::size_t node) const
{
    const std::size_t i = node % std::size_t(nx_ + 1), j = node / std::size_t(nx_ + 1);
    return std::ptrdiff_t(j) * stride_ + std::ptrdiff_t(i);
}

template <typename T>
double PlateEngine<T>::force_gain(std::size_t node) const
{
    const std::ptrdiff_t u = op_->unknown_of()[node];
    if (u < 0)
        return 0.0;
    const double d = 1.0 / (1.0 + op_->params().loss.sigma0 * k_);
    return d * k_ * k_ / op_->mass()[u];
}

// Every rigid_interval steps a free plate's rigid-body momenta are restored
// to their exact values (plate_engine_rigid.cpp).
constexpr std::size_t rigid_interval = 16;

template <typename T>
void PlateEngine<T>::add_displacement(std::ptrdiff_t offset, T delta_m)
{
    u_[offset] += delta_m;
    inc_[offset] += delta_m;
    scanned_clean_ = no_scan;
    const int i = int(offset % stride_), j = int(offset / stride_);
    if (mirror_edges_ && (i <= 1 || i >= nx_ - 1 || j <= 1 || j >= ny_ - 1))
        ghosts_stale_ = true; // a node a ghost mirrors changed after the sweep
    if (rigid_count_ == 0)
        return;
    const std::ptrdiff_t u = op_->unknown_of()[op_->grid().node(i, j)];
    if (u < 0)
        return;
    const double md = op_->mass()[Eigen::Index(u)] * double(delta_m);
    for (int c = 0; c < rigid_count_; ++c) {
        const auto &b = rigid_b_[std::size_t(c)];
        rigid_expected_[std::size_t(c)] += md * (b[0] + b[1] * i + b[2] * j);
    }
}

template <typename T>
std::size_t PlateEngine<T>::add_source(double x_m, double y_m)
{
    PointTap tap;
    for (const auto &nw : op_->point_weights(x_m, y_m)) {
        tap.offset.push_back(offset_of(nw.node));
        tap.weight.push_back(T(nw.weight * force_gain(nw.node)));
    }
    sources_.push_back(std::move(tap));
    return sources_.size() - 1;
}

template <typename T>
std::size_t PlateEngine<T>::add_receiver(double x_m, double y_m)
{
    PointTap tap;
    for (const auto &nw : op_->point_weights(x_m, y_m)) {
        tap.offset.push_back(offset_of(nw.node));
        tap.weight.push_back(T(nw.weight));
    }
    int first = tap.offset.empty() ? 1 : ny_, last = 1; // the rows it reads (none: read anywhere)
    for (std::ptrdiff_t o : tap.offset) {
        first = std::min(first, int(o / stride_));
        last = std::max(last, int(o / stride_));
    }
    if (last > first + 1)
        throw std::logic_error("PlateEngine::add_receiver: a receiver reads more than two rows");
    receiver_rows_.emplace_back(first, last);
    block_reads_stale_ = true;
    receivers_.push_back(std::move(tap));
    return receivers_.size() - 1;
}

template <typename T>
double PlateEngine<T>::receiver_value(std::size_t r) const
{
    return receiver_value(r, BlockBelow{});
}

template <typename T>
double PlateEngine<T>::receiver_value(std::size_t r, const BlockBelow &below) const
{
    const PointTap &tap = receivers_[r];
    const T *copy = static_cast<const T *>(below.rows);
    double v = 0;
    for (std::size_t n = 0; n < tap.offset.size(); ++n) {
        const std::ptrdiff_t o = tap.offset[n];
        const T x = o >= below.first && o < below.last ? copy[o - below.first] : u_[o];
        v += double(tap.weight[n]) * double(x);
    }
    return v;
}

template <typename T>
void PlateEngine<T>::step()
{
    if (lossy_)
        step_impl<true>();
    else
        step_impl<false>();
}

template <typename T>
template <bool Lossy>
void PlateEngine<T>::step_impl()
{
    // The edge band first, into band_next_: its strains read u^n and d^n
    // around the band, which the bulk then updates in place. Mirrored edges
    // have no band: the ghosts of u^n, and the bulk runs up to the edge.
    int margin = 2;
    if (mirror_edges_) {
        // The previous sweep refreshed the ghosts (plate_kernels.h); a pass
        // only after a change next to an edge outside it.
        refresh_stale_ghosts();
        margin = 1;
    } else {
        edge_band_update<Lossy>();
    }
    const double g = double(bulk_.g);
    // The bulk: d^{n+1} into inc_before_ (d^{n-1} is no longer needed), u in place.
    const int i0 = margin, i1 = nx_ + 1 - margin, j0 = margin, j1 = ny_ + 1 - margin;
    if (i1 > i0 && j1 > j0)
        bulk_update_threads<T, Lossy>(u_, inc_, inc_before_, stride_, i0, i1, j0, j1, bulk_, bulk_threads_, scratch_);
    for (const BandRow &row : band_rows_) {
        const T v = T(band_next_[row.slot]);
        inc_before_[row.target] = v;
        u_[row.target] += v;
    }
    std::swap(inc_, inc_before_);
    for (int c = 0; c < rigid_count_; ++c)
        rigid_expected_[std::size_t(c)] *= g;
    apply_sources();
    ++steps_;
    if (rigid_count_ > 0 && steps_ % rigid_interval == 0)
        restore_rigid_momenta();
    for (auto &ext : extensions_)
        ext->after_update(*this);
}

template <typename T>
void PlateEngine<T>::apply_sources()
{
    for (PointTap &src : sources_) {
        if (src.force == T(0))
            continue;
        for (std::size_t n = 0; n < src.offset.size(); ++n)
            add_displacement(src.offset[n], src.weight[n] * src.force);
    }
}

template <typename T>
void PlateEngine<T>::build_block_reads()
{
    BlockReads &br = block_reads_;
    br.first.assign(std::size_t(ny_) + 2, 0);
    for (const auto &rows : receiver_rows_)
        ++br.first[std::size_t(rows.second) + 1];
    for (std::size_t j = 1; j < br.first.size(); ++j)
        br.first[j] += br.first[j - 1];
    br.receiver.assign(receivers_.size(), 0);
    std::vector<std::uint32_t> next(br.first.begin(), br.first.end() - 1);
    for (std::size_t r = 0; r < receivers_.size(); ++r)
        br.receiver[next[std::size_t(receiver_rows_[r].second)]++] = std::uint32_t(r);
    br.rows.assign(std::size_t(ny_) + 1, 0);
    for (std::size_t j = 0; j < br.rows.size(); ++j)
        br.rows[j] = br.first[j + 1] > br.first[j];
    block_reads_stale_ = false;
}

template <typename T>
int PlateEngine<T>::step_block(int steps, double *between, int blocks, const std::uint8_t *scan_after)
{
    if (!can_block())
        throw std::logic_error("PlateEngine::step_block: several steps in one sweep need ghost mirrors, no extension "
                               "and rows enough for the threads");
    refresh_stale_ghosts();
    if (block_reads_stale_)
        build_block_reads();
    // Between the steps, each receiver is read once its step has updated the
    // last row it reads (the next step is two rows behind); a receiver reads
    // unknowns only (point_weights drops fixed nodes), rows 1 .. ny - 1, all
    // of which every step updates. Each (level, row) is reported once, so the
    // threads write disjoint entries.
    struct Reads {
        const PlateEngine *engine;
        double *out;
    } reads{this, between};
    auto row_done = [](void *ctx, int level, int row, const BlockBelow &below) {
        const Reads &r = *static_cast<const Reads *>(ctx);
        const BlockReads &br = r.engine->block_reads_;
        double *out = r.out + std::size_t(level - 1) * r.engine->receivers_.size();
        for (std::uint32_t i = br.first[std::size_t(row)]; i < br.first[std::size_t(row) + 1]; ++i)
            out[br.receiver[i]] = r.engine->receiver_value(br.receiver[i], below);
    };
    BlockScan scan{scan_after};
    BlockScan *const scans = scan_after ? &scan : nullptr;
    const BlockTeam team{seams_.data(), busy_.data()};
    const BlockTeam *const cut = seams_.empty() ? nullptr : &team;
    if (lossy_)
        bulk_update_block<T, true>(u_, inc_, stride_, 1, nx_, 1, ny_, bulk_, steps, bulk_threads_, scratch_, row_done,
                                   &reads, block_reads_.rows.data(), blocks, scans, cut);
    else
        bulk_update_block<T, false>(u_, inc_, stride_, 1, nx_, 1, ny_, bulk_, steps, bulk_threads_, scratch_, row_done,
                                    &reads, block_reads_.rows.data(), blocks, scans, cut);
    const int done = scan_after ? scan.blocks_done : blocks;
    // The team's seams follow its threads' speeds, measured over
    // balance_blocks blocks at a time.
    if (cut) {
        for (std::size_t t = 0; t < busy_.size(); ++t)
            busy_sum_[t] += busy_[t];
        if ((busy_blocks_ += std::size_t(done)) >= balance_blocks) {
            balance_seams(seams_.data(), busy_sum_.data(), bulk_threads_);
            std::fill(busy_sum_.begin(), busy_sum_.end(), 0.0);
            busy_blocks_ = 0;
        }
    }
    steps_ += std::size_t(steps) * std::size_t(done);
    // The kernel's scan of the newest level, for non_finite_report, unless a
    // source's force changes it below (add_displacement forgets it).
    if (scan_after && scan_after[done - 1] && !scan.found)
        scanned_clean_ = steps_;
    // inc_ holds d^{n+steps}, the newest increment, as after as many step()s.
    apply_sources();
    return done;
}

template <typename T>
double PlateEngine<T>::energy() const
{
    const PlateOperator &op = *op_;
    const Eigen::Index n = Eigen::Index(op.unknown_count());
    Eigen::VectorXd a(n), inc(n);
    for (Eigen::Index u = 0; u < n; ++u) {
        const std::ptrdiff_t off = offset_of(op.node_of()[std::size_t(u)]);
        a[u] = double(u_[off]);
        inc[u] = double(inc_[off]);
    }
    const Eigen::VectorXd b = a - inc;
    const Eigen::VectorXd v = inc / k_;
    double kinetic = v.dot(op.mass().cwiseProduct(v));
    const double sigma1 = op.params().loss.sigma1;
    if (sigma1 > 0)
        kinetic -= sigma1 * k_ * v.dot(op.dirichlet() * v);
    const double potential = a.dot(op.stiffness() * b);
    return 0.5 * kinetic + 0.5 * potential;
}

template <typename T>
std::vector<double> PlateEngine<T>::displacement() const
{
    std::vector<double> out(std::size_t(nx_ + 1) * std::size_t(ny_ + 1));
    for (int j = 0; j <= ny_; ++j)
        for (int i = 0; i <= nx_; ++i)
            out[std::size_t(j) * std::size_t(nx_ + 1) + std::size_t(i)] = double(u_[j * stride_ + i]);
    return out;
}

template <typename T>
void PlateEngine<T>::set_state(const std::vector<double> &current, const std::vector<double> &previous)
{
    const std::size_t nodes = op_->grid().node_count();
    if (current.size() != nodes || previous.size() != nodes)
        throw std::invalid_argument("PlateEngine::set_state: field size does not match the grid");
    for (std::size_t node = 0; node < nodes; ++node) {
        const bool fixed = op_->unknown_of()[node] < 0;
        u_[offset_of(node)] = fixed ? T(0) : T(current[node]);
        inc_[offset_of(node)] = fixed ? T(0) : T(current[node] - previous[node]);
        inc_before_[offset_of(node)] = T(0);
    }
    ghosts_stale_ = true;
    scanned_clean_ = no_scan;
    const auto raw = raw_moments();
    for (int c = 0; c < rigid_count_; ++c) {
        const auto &b = rigid_b_[std::size_t(c)];
        rigid_expected_[std::size_t(c)] = b[0] * raw[0] + b[1] * raw[1] + b[2] * raw[2];
    }
}

template class PlateEngine<float>;
template class PlateEngine<double>;

} // namespace calib::engine
