#include "engine/simulation.h"

#include "engine/effects/finger.h"
#include "engine/mindlin/mindlin_engine.h"
#include "engine/spectrum.h"
#include "io/format.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <optional>
#include <type_traits>

namespace calib::engine {

namespace {

// The most blocks of steps one parallel region runs (Simulation::run), and
// the most bytes of receiver values they leave between (many receivers: the
// values of fewer blocks stay in cache until they are copied out).
constexpr std::size_t run_max_blocks = 64;
constexpr std::size_t run_max_bytes = 64 * 1024;

using io::fmt;

} // namespace

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

double kirchhoff_time_step(const PlateOperator &op, const SimulationOptions &options)
{
    if (options.time_step_s > 0) {
        if (!options.engine.skip_stability_check)
            check_stable_time_step(op, options.time_step_s);
        return options.time_step_s;
    }
    if (!(options.courant > 0 && options.courant < 1))
        throw std::invalid_argument("courant factor must lie in (0, 1)");
    return options.courant * op.max_time_step();
}

const char *precision_name(Precision p) { return p == Precision::f32 ? "float" : "double"; }

Simulation::Simulation(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options)
    : op_(std::move(op)), options_(options)
{
    if (options_.thick_plate) {
        std::shared_ptr<const mindlin::MindlinOperator> m = options_.thick_plate_operator;
        if (!m)
            m = std::make_shared<const mindlin::MindlinOperator>(op_->params(), op_->grid());
        else if (m->grid().nx != op_->grid().nx || m->grid().ny != op_->grid().ny || m->grid().h != op_->grid().h)
            throw std::invalid_argument("thick_plate: the Mindlin operator is of another grid than the plate");
        options_.precision = Precision::f64; // the Mindlin engine is double only
        if (options_.time_step_s > 0)
            k_ = options_.time_step_s; // MindlinEngine checks it against its own bound
        else if (!(options_.courant > 0 && options_.courant < 1))
            throw std::invalid_argument("courant factor must lie in (0, 1)");
        else
            k_ = options_.courant * m->max_time_step();
        engine_ = std::make_unique<mindlin::MindlinEngine>(std::move(m), k_);
        return;
    }
    k_ = kirchhoff_time_step(*op_, options_);
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
            auto ext = std::make_unique<effects::FingerExtension>(*e, spec);
            const effects::FingerExtension *x = ext.get();
            e->add_extension(std::move(ext));
            finger_force_.push_back([x] { return x->last_force_n(); });
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

void Simulation::set_source_impulse(std::size_t source) { set_source_signal(source, {1.0 / k_}); }

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
    const std::size_t interval = options_.field_check_interval;
    auto fail = [&](std::string msg) {
        failure_ = std::move(msg);
        throw std::runtime_error(failure_);
    };
    // Scans the newest field (or state); on a non-finite value the engine
    // reports what and where, and this adds who found it and the last clean scan.
    auto scan = [&](auto &e, const std::string &detected_by) {
        const std::string what = e->non_finite_report();
        if (what.empty()) {
            last_clean_scan_ = e->steps_done();
            return;
        }
        fail("simulation diverged: " + what + "; detected by " + detected_by +
             "; the whole field was finite after step " +
             (last_clean_scan_ == 0 ? std::string("0 (the start)") : std::to_string(last_clean_scan_ - 1)));
    };
    // Step index (0-based) of the state just computed, against the lattice schedule.
    auto n_done_ok = [&](std::size_t done) {
        const std::size_t s = done - 1;
        return s >= lattice_first_ && (s - lattice_first_) % lattice_interval_ == 0;
    };
    auto record = [&](auto &e) {
        const int st = lattice_stride_;
        for (int j = 0; j <= g.ny; j += st)
            for (int i = 0; i <= g.nx; i += st)
                lattice_frames_.push_back(static_cast<float>(e->w_at(i, j)));
    };
    std::visit(
        [&](auto &e) {
            using T = typename std::remove_reference_t<decltype(*e)>::value_type;
            std::optional<ScopedFlushDenormals> ftz_team;
            std::optional<ThreadFlushDenormals> ftz_thread;
            if (e->threaded())
                ftz_team.emplace();
            else
                ftz_thread.emplace();
            // Source s's force at step `now` (0 outside its signal).
            auto force_at = [&](std::size_t s, std::size_t now) {
                const std::size_t idx = now - signal_start_[s];
                return idx < signals_[s].size() ? signals_[s][idx] : 0.0;
            };
            // Sets every source's force for step `now`; false if all are zero.
            auto set_forces = [&](std::size_t now) {
                bool any = false;
                for (std::size_t s = 0; s < signals_.size(); ++s) {
                    const std::size_t idx = now - signal_start_[s];
                    const double force = force_at(s, now);
                    if (!std::isfinite(force) || std::abs(force) > double(std::numeric_limits<T>::max()))
                        fail("non-finite force (" + fmt("%g", force) + " N" +
                             (std::isfinite(force)
                                  ? std::string(", beyond the range of ") + precision_name(options_.precision)
                                  : std::string()) +
                             ") at source " + std::to_string(s) + " at step " + std::to_string(now) +
                             " (t = " + fmt("%.6g", double(now) * k_) + " s, sample " + std::to_string(idx) +
                             " of its signal); refused before it reached the field");
                    e->set_source_force(s, force);
                    any |= T(force) != T(0);
                }
                return any;
            };
            // The receivers of the level just computed (step `now`), then the
            // lattice and the scan due after it.
            // `scanned`: a scan due after the step ran in the sweep, and the
            // level was finite (PlateEngine::step_block's scan_after).
            auto after_step = [&](std::size_t now, auto &&receiver, bool scanned = false) {
                for (std::size_t f = 0; f < finger_force_.size(); ++f)
                    finger_forces_[f].push_back(finger_force_[f]());
                bool receivers_ok = true;
                for (std::size_t r = 0; r < traces_.size(); ++r) {
                    const double v = receiver(r);
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
                    scan(e, "receiver " + std::to_string(r)); // throws if the receiver's nodes are non-finite
                    fail("non-finite value (" + fmt("%g", v) + ") read at receiver " + std::to_string(r) + " at step " +
                         std::to_string(now) + " (t = " + fmt("%.6g", double(now + 1) * k_) +
                         " s) from finite node values (overflow)");
                }
                if (lattice_stride_ > 0 && n_done_ok(now + 1))
                    record(e);
                if (interval > 0 && (now + 1) % interval == 0) {
                    if (scanned)
                        last_clean_scan_ = now + 1;
                    else
                        scan(e, "the whole-field scan");
                }
            };
            // Several steps in one sweep where nothing is due between them but
            // the receivers: no force but in the last, no lattice frame or scan
            // after any but the last.
            auto frame_due = [&](std::size_t now) { return lattice_stride_ > 0 && n_done_ok(now + 1); };
            auto scan_due = [&](std::size_t now) { return interval > 0 && (now + 1) % interval == 0; };
            auto due_after = [&](std::size_t now) { return frame_due(now) || scan_due(now); };
            constexpr bool blockable = requires { e->step_block(2, nullptr); };
            bool blocks = false;
            if constexpr (blockable)
                blocks = e->can_block() && finger_force_.empty();
            // Whether no source has a force at step `now` (a non-finite or
            // non-zero one is set, and refused, by set_forces).
            auto force_free = [&](std::size_t now) {
                for (std::size_t s = 0; s < signals_.size(); ++s)
                    if (!(T(force_at(s, now)) == T(0)))
                        return false;
                return true;
            };
            // Blocks of the largest length in a row, in one parallel region
            // (PlateEngine::step_block's `blocks`): while no step has a force,
            // nothing is due within a block, and no lattice frame but after
            // the last; the scans due after a block run in the region. At
            // most run_max_bytes of receiver values between.
            constexpr std::size_t full = bulk_max_block_steps;
            const std::size_t max_run =
                blocks ? std::clamp<std::size_t>(run_max_bytes /
                                                     (full * sizeof(double) * std::max<std::size_t>(traces_.size(), 1)),
                                                 1, run_max_blocks)
                       : 1;
            std::vector<double> between(blocks ? (max_run * full - 1) * traces_.size() : 0);
            std::vector<std::uint8_t> scan_after(max_run);
            for (std::size_t n = 0; n < steps;) {
                const std::size_t now = e->steps_done();
                if constexpr (blockable) {
                    // Whole blocks, each free of forces, nothing due within.
                    std::size_t run = 0;
                    while (blocks && run < max_run && (run + 1) * full <= steps - n) {
                        bool ok = true;
                        for (std::size_t m = run * full; m < (run + 1) * full && ok; ++m)
                            ok = force_free(now + m) && (m + 1 == (run + 1) * full || !due_after(now + m));
                        if (!ok)
                            break;
                        const std::size_t last = now + (++run) * full - 1;
                        // The scan at the end of run() too, if this is the last block.
                        scan_after[run - 1] = scan_due(last) || run * full == steps - n;
                        if (frame_due(last))
                            break;
                    }
                    if (run >= 2) {
                        set_forces(now + run * full - 1); // every one 0
                        // Fewer blocks where a scan saw a non-finite level.
                        run = std::size_t(e->step_block(int(full), between.data(), int(run), scan_after.data()));
                        for (std::size_t m = 1; m < run * full; ++m)
                            after_step(
                                now + m - 1, [&](std::size_t r) { return between[(m - 1) * traces_.size() + r]; },
                                true);
                        after_step(now + run * full - 1, [&](std::size_t r) { return e->receiver_value(r); });
                        n += run * full;
                        continue;
                    }
                }
                // The forces set last are those of the block's last step.
                std::size_t block = 1;
                if (blocks)
                    block = block_length(
                        steps - n, [&](std::size_t m) { return set_forces(now + m); },
                        [&](std::size_t m) { return due_after(now + m); });
                else
                    set_forces(now);
                if constexpr (blockable) {
                    if (block > 1) {
                        e->step_block(int(block), between.data());
                        // A non-finite level between is caught as a receiver's
                        // value; the scan then sees the level after the block.
                        for (std::size_t m = 1; m < block; ++m)
                            after_step(now + m - 1,
                                       [&](std::size_t r) { return between[(m - 1) * traces_.size() + r]; });
                        after_step(now + block - 1, [&](std::size_t r) { return e->receiver_value(r); });
                        n += block;
                        continue;
                    }
                }
                e->step();
                after_step(now, [&](std::size_t r) { return e->receiver_value(r); });
                ++n;
            }
            scan(e, "the whole-field scan at the end of the run");
        },
        engine_);
}

std::vector<double> Simulation::snapshot() const
{
    return std::visit([](auto &e) { return e->displacement(); }, engine_);
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

} // namespace calib::engine
