#include "engine/lanes.h"

#include "engine/non_finite.h"
#include "engine/plate_engine.h"
#include "engine/plate_kernels.h"
#include "io/format.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <new>

namespace calib::engine {

namespace {

using io::fmt;

// The fields of E sources of one plate, side by side (lanes.h). The storage
// follows PlateEngine's: a ghost row above and below, a ghost node left and
// right, node (1, 0) on a 64-byte line, a row stride that is no multiple of
// 4 KiB.
template <typename T, int E>
class LanesEngine {
  public:
    LanesEngine(const PlateOperator &op, double k) : op_(op), k_(k)
    {
        const Grid &g = op.grid();
        nx_ = g.nx;
        ny_ = g.ny;
        const std::ptrdiff_t per_line = std::ptrdiff_t(64 / sizeof(T));
        auto round_up = [&](std::ptrdiff_t n) { return (n + per_line - 1) / per_line * per_line; };
        // Node (1, j), the bulk's first column, starts a 64-byte line (as in PlateEngine).
        const std::ptrdiff_t prefix = round_up(2 * E) - E;
        stride_ = round_up(prefix + std::ptrdiff_t(nx_ + 2) * E);
        if (stride_ * std::ptrdiff_t(sizeof(T)) % 4096 == 0)
            stride_ += per_line;
        const std::size_t level = std::size_t(stride_) * std::size_t(ny_ + 3);
        const std::size_t total =
            3 * level + std::size_t(stride_) * std::max(bulk_scratch_rows, bulk_block_scratch_rows);
        storage_ = static_cast<T *>(std::aligned_alloc(64, total * sizeof(T)));
        if (!storage_)
            throw std::bad_alloc();
        std::memset(static_cast<void *>(storage_), 0, total * sizeof(T));
        const std::ptrdiff_t origin = stride_ + prefix;
        u_ = storage_ + origin;
        inc_ = storage_ + level + origin;
        inc_before_ = storage_ + 2 * level + origin;
        scratch_ = storage_ + 3 * level + prefix; // the kernel indexes its rows as the field's

        const Loss &loss = op.params().loss;
        lossy_ = loss.active();
        const double h = g.h;
        const double mu2 = op.kappa() * op.kappa() * k * k / (h * h * h * h);
        const double d = 1.0 / (1.0 + loss.sigma0 * k);
        bulk_.g = T(d * (1 - loss.sigma0 * k));
        bulk_.mu2 = T(d * mu2);
        bulk_.nu1 = T(d * 2 * loss.sigma1 * k / (h * h));
        bulk_.ghosts = ghost_mirrors_of<T>(op); // lanes_apply: ghost mirrors only
    }
    ~LanesEngine() { std::free(storage_); }
    LanesEngine(const LanesEngine &) = delete;
    LanesEngine &operator=(const LanesEngine &) = delete;

    std::ptrdiff_t offset_of(std::size_t node) const
    {
        const std::size_t i = node % std::size_t(nx_ + 1), j = node / std::size_t(nx_ + 1);
        return std::ptrdiff_t(j) * stride_ + std::ptrdiff_t(i) * E;
    }

    // PlateEngine::add_source's taps, in lane `lane`.
    void add_source(int lane, double x_m, double y_m)
    {
        const double d = 1.0 / (1.0 + op_.params().loss.sigma0 * k_);
        for (const auto &nw : op_.point_weights(x_m, y_m)) {
            const std::ptrdiff_t u = op_.unknown_of()[nw.node];
            const double gain = u < 0 ? 0.0 : d * k_ * k_ / op_.mass()[u];
            src_offset_.push_back(offset_of(nw.node) + lane);
            src_weight_.push_back(T(nw.weight * gain));
        }
    }
    void add_receiver(double x_m, double y_m)
    {
        Tap tap;
        for (const auto &nw : op_.point_weights(x_m, y_m)) {
            tap.offset.push_back(offset_of(nw.node));
            tap.weight.push_back(T(nw.weight));
        }
        receivers_.push_back(std::move(tap));
    }

    void step(T force)
    {
        before_sweep(force);
        if (lossy_)
            bulk_update_lanes<T, true, E>(u_, inc_, inc_before_, stride_, 1, nx_, 1, ny_, bulk_, scratch_);
        else
            bulk_update_lanes<T, false, E>(u_, inc_, inc_before_, stride_, 1, nx_, 1, ny_, bulk_, scratch_);
        std::swap(inc_, inc_before_);
        apply_force(force);
    }
    // Several steps in one sweep (bulk_update_block): no force but `force` in the last.
    void step_block(int steps, T force)
    {
        before_sweep(force);
        if (lossy_)
            bulk_update_block<T, true, E>(u_, inc_, stride_, 1, nx_, 1, ny_, bulk_, steps, 1, scratch_, nullptr,
                                          nullptr);
        else
            bulk_update_block<T, false, E>(u_, inc_, stride_, 1, nx_, 1, ny_, bulk_, steps, 1, scratch_, nullptr,
                                           nullptr);
        apply_force(force); // inc_ holds the newest increment, as after as many step()s
    }
    // The sweep refreshes the ghosts (plate_kernels.h); a whole pass after a
    // sweep whose force moved nodes outside it.
    void before_sweep(T force)
    {
        if (ghosts_stale_)
            mirror_ghosts<T, E>(u_, stride_, bulk_.ghosts);
        ghosts_stale_ = force != T(0);
    }
    void apply_force(T force)
    {
        if (force != T(0))
            for (std::size_t n = 0; n < src_offset_.size(); ++n) {
                const T delta = src_weight_[n] * force;
                u_[src_offset_[n]] += delta;
                inc_[src_offset_[n]] += delta;
            }
    }

    // Receiver r in every lane, as PlateEngine::receiver_value sums it.
    void read(std::size_t r, std::array<double, E> &out) const
    {
        out.fill(0.0);
        const Tap &tap = receivers_[r];
        for (std::size_t n = 0; n < tap.offset.size(); ++n)
            for (int l = 0; l < E; ++l)
                out[std::size_t(l)] += double(tap.weight[n]) * double(u_[tap.offset[n] + l]);
    }
    float w_at(int i, int j, int lane) const { return static_cast<float>(u_[j * stride_ + i * E + lane]); }

    // The first non-finite value in row order: false if there is none.
    bool first_non_finite(int &fi, int &fj, int &lane, double &value) const
    {
        bool bad = false;
        for (int j = 0; j <= ny_ && !bad; ++j)
            bad = any_non_finite(u_ + j * stride_, long(nx_ + 1) * E);
        if (!bad)
            return false;
        for (int j = 0; j <= ny_; ++j)
            for (int q = 0; q < (nx_ + 1) * E; ++q)
                if (!std::isfinite(double(u_[j * stride_ + q]))) {
                    fi = q / E, fj = j, lane = q % E, value = double(u_[j * stride_ + q]);
                    return true;
                }
        return true;
    }

  private:
    struct Tap {
        std::vector<std::ptrdiff_t> offset;
        std::vector<T> weight;
    };
    const PlateOperator &op_;
    double k_;
    int nx_ = 0, ny_ = 0;
    std::ptrdiff_t stride_ = 0;
    bool lossy_ = false;
    bool ghosts_stale_ = true;
    T *storage_ = nullptr;
    T *u_ = nullptr, *inc_ = nullptr, *inc_before_ = nullptr, *scratch_ = nullptr;
    BulkCoefficients<T> bulk_{};
    std::vector<std::ptrdiff_t> src_offset_;
    std::vector<T> src_weight_;
    std::vector<Tap> receivers_;
};

// One batch: sources [first, first + lanes) of the request in an engine of E
// lanes (lanes <= E; the spare lanes carry no source and stay zero).
template <typename T, int E>
void run_batch(const PlateOperator &op, double k, std::size_t check_interval, const LanesRequest &rq, std::size_t first,
               int lanes, std::vector<LaneRecord> &out)
{
    LanesEngine<T, E> eng(op, k);
    for (int l = 0; l < lanes; ++l)
        eng.add_source(l, rq.sources[first + std::size_t(l)].x_m, rq.sources[first + std::size_t(l)].y_m);
    for (const LanesRequest::Source &r : rq.receivers)
        eng.add_receiver(r.x_m, r.y_m);
    const Grid &g = op.grid();
    const int st = rq.lattice_stride;
    const std::size_t points = st > 0 ? std::size_t(g.nx / st + 1) * std::size_t(g.ny / st + 1) : 0;
    for (int l = 0; l < lanes; ++l) {
        LaneRecord &rec = out[first + std::size_t(l)];
        rec.traces.assign(rq.receivers.size(), std::vector<double>(rq.samples, 0.0));
        rec.lattice.assign(points * rq.samples, 0.0f);
    }
    if (rq.samples == 0)
        return;
    const std::size_t total = rq.first_step + (rq.samples - 1) * rq.interval + 1;
    std::size_t clean = 0; // steps done at the last scan that found nothing
    auto scan = [&](std::size_t done, const char *by) {
        int fi = 0, fj = 0, lane = 0;
        double v = 0;
        if (!eng.first_non_finite(fi, fj, lane, v)) {
            clean = done;
            return;
        }
        if (lane >= lanes) // a spare lane never holds a value
            lane = 0;
        throw SourceFailure(first + std::size_t(lane),
                            "simulation diverged: non-finite displacement (" + fmt("%g", v) + ") at step " +
                                std::to_string(done - 1) + " (t = " + fmt("%.6g", double(done) * k) +
                                " s), first at node (i, j) = (" + std::to_string(fi) + ", " + std::to_string(fj) +
                                "), (x, y) = (" + fmt("%.6g", fi * g.h) + ", " + fmt("%.6g", fj * g.h) +
                                ") m; detected by " + by + "; the whole field was finite after step " +
                                (clean == 0 ? std::string("0 (the start)") : std::to_string(clean - 1)));
    };
    std::array<double, E> value{};
    std::size_t sample = 0;
    auto force = [&](std::size_t n) { return n < rq.force_n.size() ? T(rq.force_n[n]) : T(0); };
    auto record_due = [&](std::size_t n) { return n >= rq.first_step && (n - rq.first_step) % rq.interval == 0; };
    auto scan_due = [&](std::size_t n) { return check_interval > 0 && (n + 1) % check_interval == 0; };
    for (std::size_t n = 0; n < total; ++n) {
        // Several steps in one sweep where nothing is due between them: no
        // force but in the last, no record or scan after any but the last.
        const std::size_t block = block_length(
            total - n, [&](std::size_t m) { return force(n + m) != T(0); },
            [&](std::size_t m) { return record_due(n + m) || scan_due(n + m); });
        if (block > 1) {
            eng.step_block(int(block), force(n + block - 1));
            n += block - 1;
        } else {
            eng.step(force(n));
        }
        if (record_due(n)) {
            for (std::size_t r = 0; r < rq.receivers.size(); ++r) {
                eng.read(r, value);
                for (int l = 0; l < lanes; ++l)
                    out[first + std::size_t(l)].traces[r][sample] = value[std::size_t(l)];
            }
            if (st > 0)
                for (int l = 0; l < lanes; ++l) {
                    float *frame = out[first + std::size_t(l)].lattice.data() + sample * points;
                    std::size_t p = 0;
                    for (int j = 0; j <= g.ny; j += st)
                        for (int i = 0; i <= g.nx; i += st)
                            frame[p++] = eng.w_at(i, j, l);
                }
            ++sample;
        }
        if (scan_due(n))
            scan(n + 1, "the whole-field scan");
    }
    scan(total, "the whole-field scan at the end of the run");
}

template <typename T>
void run_batch_any(int width, const PlateOperator &op, double k, std::size_t check, const LanesRequest &rq,
                   std::size_t first, int lanes, std::vector<LaneRecord> &out)
{
    switch (width) {
    case 1:
        return run_batch<T, 1>(op, k, check, rq, first, lanes, out);
    case 2:
        return run_batch<T, 2>(op, k, check, rq, first, lanes, out);
    case 4:
        return run_batch<T, 4>(op, k, check, rq, first, lanes, out);
    default:
        return run_batch<T, 8>(op, k, check, rq, first, lanes, out);
    }
}

// Time per lane of a batch of E lanes (E = 1, 2, 4, 8) against one source
// alone, on Fig. 7's 81 x 81 grid (bench_simulate's BM_SimulateLanes,
// docs/BENCHMARKS.md): the bulk kernel, which is most of a step, is bound by
// its loads, and wider rows keep the vectors full. 16 lanes measured 0.66 (the
// three levels outgrow the core's L2), so 8 is the widest.
constexpr std::array<double, 4> per_lane_cost = {1.0, 0.89, 0.79, 0.56};

} // namespace

bool lanes_apply(const PlateOperator &op, const SimulationOptions &options)
{
    const Grid &g = op.grid();
    return !options.thick_plate && op.mirror_edges() && !options.engine.edge_band_always && g.nx >= 4 && g.ny >= 4;
}

std::vector<LaneBatch> lane_batches(std::size_t count, int threads)
{
    threads = std::max(1, threads);
    // Each thread's share, cut into batches by the cheapest sum of E x cost(E)
    // (a batch of E lanes costs as much whether its lanes are all used or not).
    std::vector<LaneBatch> out;
    for (int t = 0; t < threads; ++t) {
        const std::size_t share =
            count * std::size_t(t + 1) / std::size_t(threads) - count * std::size_t(t) / std::size_t(threads);
        std::vector<double> best(share + 1, 0.0);
        std::vector<int> pick(share + 1, 1);
        for (std::size_t n = 1; n <= share; ++n) {
            best[n] = std::numeric_limits<double>::infinity();
            for (int w = 0; w < 4; ++w) {
                const int e = 1 << w;
                const std::size_t used = std::min<std::size_t>(std::size_t(e), n);
                const double c = e * per_lane_cost[std::size_t(w)] + best[n - used];
                if (c < best[n]) {
                    best[n] = c;
                    pick[n] = e;
                }
            }
        }
        for (std::size_t n = share; n > 0;) {
            const int e = pick[n];
            const std::size_t used = std::min<std::size_t>(std::size_t(e), n);
            out.push_back({int(used), e});
            n -= used;
        }
    }
    std::stable_sort(out.begin(), out.end(), [](const LaneBatch &a, const LaneBatch &b) { return a.width > b.width; });
    return out;
}

std::vector<LaneRecord> simulate_lanes(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options,
                                       const LanesRequest &rq,
                                       const std::function<void(std::size_t, std::size_t)> &progress)
{
    if (!op)
        throw std::invalid_argument("simulate_lanes: no operator");
    if (!lanes_apply(*op, options))
        throw std::invalid_argument("simulate_lanes: a free edge, the thick plate or a grid under 4 x 4 cells");
    if (rq.interval < 1 || rq.lattice_stride < 0)
        throw std::invalid_argument("simulate_lanes: the interval must be >= 1 and the lattice stride >= 0");
    const double k = kirchhoff_time_step(*op, options);
    if (!options.engine.skip_stability_check)
        op->check_time_step(k);
    const bool single = options.precision == Precision::f32;
    const double limit = single ? double(std::numeric_limits<float>::max()) : std::numeric_limits<double>::max();
    for (std::size_t n = 0; n < rq.force_n.size() && !rq.sources.empty(); ++n)
        if (!std::isfinite(rq.force_n[n]) || std::abs(rq.force_n[n]) > limit)
            throw SourceFailure(0, "non-finite force (" + fmt("%g", rq.force_n[n]) + " N" +
                                       (std::isfinite(rq.force_n[n])
                                            ? std::string(", beyond the range of ") + precision_name(options.precision)
                                            : std::string()) +
                                       ") at step " + std::to_string(n) + " (t = " + fmt("%.6g", double(n) * k) +
                                       " s); refused before it reached the field");

    // Points off the plate are refused here, named, not inside the team
    // (an exception cannot leave an OpenMP region).
    for (std::size_t n = 0; n < rq.sources.size(); ++n)
        try {
            (void)op->point_weights(rq.sources[n].x_m, rq.sources[n].y_m);
        } catch (const std::exception &e) {
            throw SourceFailure(n, std::string("source: ") + e.what());
        }
    for (std::size_t n = 0; n < rq.receivers.size(); ++n)
        try {
            (void)op->point_weights(rq.receivers[n].x_m, rq.receivers[n].y_m);
        } catch (const std::exception &e) {
            throw std::invalid_argument("simulate_lanes: receiver " + std::to_string(n) + ": " + e.what());
        }
    const int threads = options.engine.threads > 0 ? options.engine.threads : omp_get_max_threads();
    if (rq.width != 0 && rq.width != 1 && rq.width != 2 && rq.width != 4 && rq.width != 8)
        throw std::invalid_argument("simulate_lanes: width must be 0, 1, 2, 4 or 8");
    std::vector<LaneBatch> plan;
    if (rq.width == 0)
        plan = lane_batches(rq.sources.size(), threads);
    else
        for (std::size_t n = 0; n < rq.sources.size(); n += std::size_t(rq.width))
            plan.push_back({int(std::min<std::size_t>(std::size_t(rq.width), rq.sources.size() - n)), rq.width});
    std::vector<std::size_t> firsts;
    std::size_t first = 0;
    for (const LaneBatch &b : plan) {
        firsts.push_back(first);
        first += std::size_t(b.lanes);
    }
    std::vector<LaneRecord> out(rq.sources.size());
    std::size_t done = 0;
    if (progress && !plan.empty())
        progress(0, rq.sources.size()); // the start: a batch reports only when it ends
    bool failed = false;
    std::size_t failed_source = 0;
    std::string failure;
#pragma omp parallel for schedule(dynamic, 1) num_threads(std::max(1, std::min <int>(threads, int(plan.size()))))
    for (std::size_t b = 0; b < plan.size(); ++b) {
        try {
            ThreadFlushDenormals ftz;
            if (single)
                run_batch_any<float>(plan[b].width, *op, k, options.field_check_interval, rq, firsts[b], plan[b].lanes,
                                     out);
            else
                run_batch_any<double>(plan[b].width, *op, k, options.field_check_interval, rq, firsts[b], plan[b].lanes,
                                      out);
        } catch (const std::exception &e) { // a batch that could not run (memory) is its first source's failure
            const auto *lane = dynamic_cast<const SourceFailure *>(&e);
            const std::size_t source = lane ? lane->source() : firsts[b];
#pragma omp critical(lanes_state)
            if (!failed || source < failed_source) {
                failed = true;
                failed_source = source;
                failure = e.what();
            }
        }
#pragma omp critical(lanes_state)
        {
            done += std::size_t(plan[b].lanes);
            if (progress)
                progress(done, rq.sources.size());
        }
    }
    if (failed)
        throw SourceFailure(failed_source, failure);
    return out;
}

} // namespace calib::engine
