#include "engine/simulation.h"

#include "engine/effects/finger.h"
#include "engine/effects/thick_plate.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <optional>
#include <type_traits>

#include <omp.h>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define SIMULATION_HAVE_MXCSR 1
#endif

namespace calib::engine {

namespace {

// Flush-to-zero and denormals-are-zero on this thread only. A single-threaded
// run needs no more; ScopedFlushDenormals also forks an OpenMP team to set
// the workers' flags, and that fork/join per run() call cost 25 ms on a
// loaded 2-core machine (run(500) on a 40 x 30 grid: 56 instead of 2.3 us per
// step; docs/engine.md, "Stability suite").
class ThreadFlushDenormals {
public:
    ThreadFlushDenormals()
    {
#ifdef SIMULATION_HAVE_MXCSR
        saved_ = _mm_getcsr();
        _mm_setcsr(saved_ | 0x8040u);
#endif
    }
    ~ThreadFlushDenormals()
    {
#ifdef SIMULATION_HAVE_MXCSR
        _mm_setcsr(saved_);
#endif
    }
    ThreadFlushDenormals(const ThreadFlushDenormals &) = delete;
    ThreadFlushDenormals &operator=(const ThreadFlushDenormals &) = delete;

private:
    unsigned saved_ = 0;
};

// Whether PlateEngine::step() will run its bulk update on more than one
// thread (the rule of PlateEngine::step_impl).
bool engine_threads(const Grid &g, const EngineOptions &o)
{
    const long cells = long(std::max(0, g.nx - 3)) * long(std::max(0, g.ny - 3));
    const int threads = o.threads > 0 ? o.threads : omp_get_max_threads();
    return threads > 1 && std::size_t(cells) >= o.parallel_min_cells;
}

// True if any of n values is NaN or +-Inf: the exponent bits are all ones,
// so adding the exponent's lowest bit to them carries into the sign bit. Pure
// integer and/add/or, vectorized by `omp simd` for both widths (-O2's cost
// model would leave it scalar: measured 1.6 ns per node, as much as a whole
// step).
template <typename T>
bool any_non_finite(const T *p, int n)
{
    using Bits = std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>;
    constexpr int mantissa = sizeof(T) == 4 ? 23 : 52;
    constexpr Bits exponent = sizeof(T) == 4 ? Bits(0x7f800000u) : Bits(0x7ff0000000000000ull);
    Bits bad = 0;
#pragma omp simd reduction(| : bad)
    for (int i = 0; i < n; ++i) {
        Bits b;
        std::memcpy(&b, p + i, sizeof b);
        bad |= (b & exponent) + (Bits(1) << mantissa);
    }
    return (bad >> (8 * sizeof(Bits) - 1)) != 0;
}

std::string fmt(const char *f, double a)
{
    char buf[64];
    std::snprintf(buf, sizeof buf, f, a);
    return buf;
}

// Limits OpenMP to this thread while an operator's stability bound is found:
// Lanczos' sparse products go through Eigen, which forks a team per product;
// on the loaded 2-core machine that made a 130 000-unknown Mindlin bound take
// 3 s instead of 0.2 s (and the Kirchhoff one 1 s instead of 0.05 s).
// omp_set_num_threads changes only the calling thread's setting.
class SerialEigen {
public:
    SerialEigen() : saved_(omp_get_max_threads()) { omp_set_num_threads(1); }
    ~SerialEigen() { omp_set_num_threads(saved_); }
    SerialEigen(const SerialEigen &) = delete;
    SerialEigen &operator=(const SerialEigen &) = delete;

private:
    int saved_;
};

// The Mindlin operator of a plate operator, built once (assembly + Lanczos
// bound, computed here under the lock so the shared operator is read-only
// afterwards) and shared by every simulation of that plate: the pipeline's
// foci run in parallel on one PlateOperator. One entry: a calibration uses
// one plate.
std::shared_ptr<const effects::MindlinOperator> mindlin_of(const std::shared_ptr<const PlateOperator> &op)
{
    static std::mutex lock;
    static std::weak_ptr<const PlateOperator> key;
    static std::shared_ptr<const effects::MindlinOperator> value;
    std::lock_guard<std::mutex> guard(lock);
    if (value && key.lock() == op)
        return value;
    SerialEigen serial;
    auto m = std::make_shared<effects::MindlinOperator>(op->params(), op->grid());
    m->lambda_max();
    key = op;
    value = m;
    return value;
}

// The value type an engine stores its field in.
template <typename E>
struct ValueOf {
    using type = double;  // MindlinEngine
};
template <typename T>
struct ValueOf<PlateEngine<T>> {
    using type = T;
};

}  // namespace

void check_stable_time_step(const PlateOperator &op, double k)
{
    const double sigma1 = op.params().loss.sigma1;
    if (sigma1 > 0 && k > 0 && k >= op.max_time_step()) {
        const double lossless = 2 / std::sqrt(op.lambda_max_stiffness());
        if (k < lossless) {
            char buf[420];
            std::snprintf(buf, sizeof buf,
                          "time step %.6g s is not below the stability bound %.6g s of the assembled plate operator "
                          "with loss: the frequency-dependent loss sigma1 = %.4g m^2/s breaks the explicit bound "
                          "(k^2/4 lambda_K + sigma1 k lambda_G = %.4g > 1; without loss the bound would be %.6g s); "
                          "shorten the step or lengthen the high-frequency T60",
                          k, op.max_time_step(), sigma1,
                          k * k / 4 * op.lambda_max_stiffness() + sigma1 * k * op.lambda_max_dirichlet(), lossless);
            throw std::invalid_argument(buf);
        }
    }
    op.check_time_step(k);
}

const char *precision_name(Precision p)
{
    return p == Precision::f32 ? "float" : "double";
}

Simulation::Simulation(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options)
    : op_(std::move(op)), options_(options)
{
    if (options_.thick_plate) {
        std::shared_ptr<const effects::MindlinOperator> m;
        try {
            m = mindlin_of(op_);
        } catch (const std::invalid_argument &e) {
            throw std::invalid_argument(std::string("thick_plate: ") + e.what());
        }
        options_.precision = Precision::f64;  // the Mindlin engine is double only
        if (options_.time_step_s > 0)
            k_ = options_.time_step_s;  // MindlinEngine checks it against its own bound
        else if (!(options_.courant > 0 && options_.courant < 1))
            throw std::invalid_argument("courant factor must lie in (0, 1)");
        else
            k_ = options_.courant * m->max_time_step();
        engine_ = std::make_unique<effects::MindlinEngine>(std::move(m), k_);
        return;
    }
    SerialEigen serial;  // for the bound, found here on first use
    if (options_.time_step_s > 0) {
        k_ = options_.time_step_s;
        if (!options_.engine.skip_stability_check)
            check_stable_time_step(*op_, k_);
    } else {
        if (!(options_.courant > 0 && options_.courant < 1))
            throw std::invalid_argument("courant factor must lie in (0, 1)");
        k_ = options_.courant * op_->max_time_step();
    }
    if (options_.precision == Precision::f32)
        engine_ = std::make_unique<PlateEngine<float>>(op_, k_, options_.engine);
    else
        engine_ = std::make_unique<PlateEngine<double>>(op_, k_, options_.engine);
}

Simulation::~Simulation() = default;
Simulation::Simulation(Simulation &&) noexcept = default;
Simulation &Simulation::operator=(Simulation &&) noexcept = default;

std::size_t Simulation::add_finger(const effects::FingerSpec &spec)
{
    std::visit(
        [&](auto &e) {
            using E = std::remove_reference_t<decltype(*e)>;
            if constexpr (std::is_same_v<E, effects::MindlinEngine>) {
                const std::size_t f = e->add_finger(spec);
                const effects::MindlinEngine *m = e.get();
                finger_force_.push_back([m, f] { return m->finger_force_n(f); });
            } else {
                using T = typename E::value_type;
                auto ext = std::make_unique<effects::FingerExtension<T>>(*e, spec);
                const effects::FingerExtension<T> *x = ext.get();
                e->add_extension(std::move(ext));
                finger_force_.push_back([x] { return x->last_force_n(); });
            }
        },
        engine_);
    finger_forces_.emplace_back();
    return finger_forces_.size() - 1;
}

std::size_t Simulation::steps_done() const
{
    return std::visit([](auto &e) { return e->steps_done(); }, engine_);
}

std::size_t Simulation::add_source(double x_m, double y_m)
{
    std::visit([&](auto &e) { e->add_source(x_m, y_m); }, engine_);
    signals_.emplace_back();
    signal_start_.push_back(steps_done());
    return signals_.size() - 1;
}

std::size_t Simulation::add_receiver(double x_m, double y_m)
{
    std::visit([&](auto &e) { e->add_receiver(x_m, y_m); }, engine_);
    traces_.emplace_back();
    return traces_.size() - 1;
}

void Simulation::set_source_signal(std::size_t source, std::vector<double> force_n)
{
    signals_.at(source) = std::move(force_n);
    signal_start_.at(source) = steps_done();
}

void Simulation::set_source_impulse(std::size_t source)
{
    set_source_signal(source, {1.0 / k_});
}

std::size_t Simulation::steps_for(double duration_s) const
{
    if (!(duration_s >= 0) || !std::isfinite(duration_s))
        throw std::invalid_argument("duration must be >= 0");
    return std::size_t(std::ceil(duration_s / k_ - 1e-9));
}

void Simulation::run(std::size_t steps)
{
    if (!failure_.empty())
        throw std::runtime_error(failure_ + " (the simulation stopped there)");
    for (auto &t : traces_)
        t.reserve(t.size() + steps);
    const Grid &g = op_->grid();
    const double h = g.h;
    const std::size_t interval = options_.field_check_interval;
    auto fail = [&](std::string msg) {
        failure_ = std::move(msg);
        throw std::runtime_error(failure_);
    };
    // Scans the newest field; on a non-finite value reports the first node (in
    // row order), how many there are and their extent, and the last clean scan.
    auto scan_kirchhoff = [&](auto &e, const std::string &detected_by) {
        const auto *f = e->newest_field();
        const std::ptrdiff_t stride = e->stride();
        bool bad = false;
        for (int j = 0; j <= g.ny && !bad; ++j)
            bad = any_non_finite(f + j * stride, g.nx + 1);
        const std::size_t n = e->steps_done();
        if (!bad) {
            last_clean_scan_ = n;
            return;
        }
        int fi = -1, fj = -1, i0 = g.nx, i1 = 0, j0 = g.ny, j1 = 0;
        std::size_t count = 0;
        double first = 0;
        for (int j = 0; j <= g.ny; ++j)
            for (int i = 0; i <= g.nx; ++i) {
                const double v = double(f[j * stride + i]);
                if (std::isfinite(v))
                    continue;
                if (count++ == 0) {
                    fi = i;
                    fj = j;
                    first = v;
                }
                i0 = std::min(i0, i), i1 = std::max(i1, i), j0 = std::min(j0, j), j1 = std::max(j1, j);
            }
        std::string msg = "simulation diverged: non-finite displacement (" + fmt("%g", first) + ") at step " +
                          std::to_string(n - 1) + " (t = " + fmt("%.6g", double(n) * k_) + " s), first at node (i, j) = (" +
                          std::to_string(fi) + ", " + std::to_string(fj) + "), (x, y) = (" + fmt("%.6g", fi * h) + ", " +
                          fmt("%.6g", fj * h) + ") m; " + std::to_string(count) + " non-finite nodes in i " +
                          std::to_string(i0) + ".." + std::to_string(i1) + ", j " + std::to_string(j0) + ".." +
                          std::to_string(j1) + "; detected by " + detected_by + "; the whole field was finite after step " +
                          (last_clean_scan_ == 0 ? std::string("0 (the start)") : std::to_string(last_clean_scan_ - 1));
        fail(msg);
    };
    // The Mindlin state [w | psi_x | psi_y]: the same scan over all unknowns;
    // located at the first non-finite w node, else at the first rotation.
    auto scan_mindlin = [&](const effects::MindlinEngine &e, const std::string &detected_by) {
        const Eigen::VectorXd &q = e.state();
        const std::size_t n = e.steps_done();
        if (!any_non_finite(q.data(), int(q.size()))) {
            last_clean_scan_ = n;
            return;
        }
        const effects::MindlinOperator &m = e.plate();
        std::size_t count = 0;
        Eigen::Index first = -1;
        for (Eigen::Index u = 0; u < q.size(); ++u)
            if (!std::isfinite(q[u]) && count++ == 0)
                first = u;
        std::string where;
        for (int j = 0; j <= g.ny && where.empty(); ++j)
            for (int i = 0; i <= g.nx && where.empty(); ++i) {
                const std::ptrdiff_t u = m.w_index(i, j);
                if (u >= 0 && !std::isfinite(q[u]))
                    where = "first w at node (i, j) = (" + std::to_string(i) + ", " + std::to_string(j) + "), (x, y) = (" +
                            fmt("%.6g", i * h) + ", " + fmt("%.6g", j * h) + ") m";
            }
        if (where.empty())
            where = "first at rotation unknown " + std::to_string(first - Eigen::Index(m.w_count())) + " (w still finite)";
        fail("simulation diverged (thick_plate): non-finite value (" + fmt("%g", q[first]) + ") at step " +
             std::to_string(n - 1) + " (t = " + fmt("%.6g", double(n) * k_) + " s), " + where + "; " +
             std::to_string(count) + " non-finite unknowns of " + std::to_string(q.size()) + "; detected by " +
             detected_by + "; the whole state was finite after step " +
             (last_clean_scan_ == 0 ? std::string("0 (the start)") : std::to_string(last_clean_scan_ - 1)));
    };
    auto scan = [&](auto &e, const std::string &detected_by) {
        using E = std::remove_reference_t<decltype(*e)>;
        if constexpr (std::is_same_v<E, effects::MindlinEngine>)
            scan_mindlin(*e, detected_by);
        else
            scan_kirchhoff(e, detected_by);
    };
    // Step index (0-based) of the state just computed, against the lattice schedule.
    auto n_done_ok = [&](std::size_t done) {
        const std::size_t s = done - 1;
        return s >= lattice_first_ && (s - lattice_first_) % lattice_interval_ == 0;
    };
    auto record = [&](auto &e) {
        using E = std::remove_reference_t<decltype(*e)>;
        const int st = lattice_stride_;
        for (int j = 0; j <= g.ny; j += st)
            for (int i = 0; i <= g.nx; i += st) {
                if constexpr (std::is_same_v<E, effects::MindlinEngine>) {
                    const std::ptrdiff_t u = e->plate().w_index(i, j);
                    lattice_frames_.push_back(u >= 0 ? static_cast<float>(e->state()[u]) : 0.0f);
                } else {
                    lattice_frames_.push_back(static_cast<float>(e->newest_field()[j * e->stride() + i]));
                }
            }
    };
    std::visit(
        [&](auto &e) {
            using E = std::remove_reference_t<decltype(*e)>;
            constexpr bool mindlin = std::is_same_v<E, effects::MindlinEngine>;
            std::optional<ScopedFlushDenormals> ftz_team;
            std::optional<ThreadFlushDenormals> ftz_thread;
            bool team = false;
            if constexpr (mindlin)
                team = e->plate().unknown_count() > 200000;  // MindlinEngine::step's OpenMP threshold
            else
                team = engine_threads(g, options_.engine);
            if (team)
                ftz_team.emplace();
            else
                ftz_thread.emplace();
            for (std::size_t n = 0; n < steps; ++n) {
                const std::size_t now = e->steps_done();
                for (std::size_t s = 0; s < signals_.size(); ++s) {
                    const std::size_t idx = now - signal_start_[s];
                    const double force = idx < signals_[s].size() ? signals_[s][idx] : 0.0;
                    using T = typename ValueOf<E>::type;
                    if (!std::isfinite(force) || std::abs(force) > double(std::numeric_limits<T>::max()))
                        fail("non-finite force (" + fmt("%g", force) + " N" +
                             (std::isfinite(force) ? std::string(", beyond the range of ") + precision_name(options_.precision)
                                                   : std::string()) +
                             ") at source " + std::to_string(s) + " at step " + std::to_string(now) + " (t = " +
                             fmt("%.6g", double(now) * k_) + " s, sample " + std::to_string(idx) +
                             " of its signal); refused before it reached the field");
                    e->set_source_force(s, force);
                }
                e->step();
                for (std::size_t f = 0; f < finger_force_.size(); ++f)
                    finger_forces_[f].push_back(finger_force_[f]());
                bool receivers_ok = true;
                for (std::size_t r = 0; r < traces_.size(); ++r) {
                    const double v = e->receiver_value(r);
                    traces_[r].push_back(v);
                    receivers_ok &= std::isfinite(v);
                }
                if (!receivers_ok) {
                    std::size_t r = 0;
                    while (std::isfinite(traces_[r].back()))
                        ++r;
                    const double v = traces_[r].back();
                    for (auto &t : traces_)
                        t.pop_back();
                    scan(e, "receiver " + std::to_string(r));  // throws if the receiver's nodes are non-finite
                    fail("non-finite value (" + fmt("%g", v) + ") read at receiver " + std::to_string(r) + " at step " +
                         std::to_string(now) + " (t = " + fmt("%.6g", double(now + 1) * k_) +
                         " s) from finite node values (overflow)");
                }
                if (lattice_stride_ > 0 && n_done_ok(e->steps_done()))
                    record(e);
                if (interval > 0 && e->steps_done() % interval == 0)
                    scan(e, "the whole-field scan");
            }
            scan(e, "the whole-field scan at the end of the run");
        },
        engine_);
}

std::vector<double> Simulation::snapshot() const
{
    return std::visit(
        [&](auto &e) {
            using E = std::remove_reference_t<decltype(*e)>;
            if constexpr (std::is_same_v<E, effects::MindlinEngine>) {
                const Grid &g = op_->grid();
                std::vector<double> w(std::size_t(g.nx + 1) * std::size_t(g.ny + 1), 0.0);
                for (int j = 0; j <= g.ny; ++j)
                    for (int i = 0; i <= g.nx; ++i)
                        if (const std::ptrdiff_t u = e->plate().w_index(i, j); u >= 0)
                            w[g.node(i, j)] = e->state()[u];
                return w;
            } else {
                return e->displacement();
            }
        },
        engine_);
}

void Simulation::record_lattice(int stride, std::size_t first_step, std::size_t interval)
{
    if (stride < 1 || interval < 1)
        throw std::invalid_argument("record_lattice: stride and interval must be >= 1");
    lattice_stride_ = stride;
    lattice_first_ = first_step;
    lattice_interval_ = interval;
}

double Simulation::energy() const
{
    return std::visit([](auto &e) { return e->energy(); }, engine_);
}

}  // namespace calib::engine
