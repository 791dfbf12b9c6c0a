#include "engine/simulation.h"

#include <cmath>
#include <stdexcept>

namespace calib::engine {

const char *precision_name(Precision p)
{
    return p == Precision::f32 ? "float" : "double";
}

Simulation::Simulation(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options)
    : op_(std::move(op)), options_(options)
{
    if (options_.time_step_s > 0) {
        k_ = options_.time_step_s;
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
    for (auto &t : traces_)
        t.reserve(t.size() + steps);
    std::visit(
        [&](auto &e) {
            ScopedFlushDenormals ftz;
            for (std::size_t n = 0; n < steps; ++n) {
                const std::size_t now = e->steps_done();
                for (std::size_t s = 0; s < signals_.size(); ++s) {
                    const std::size_t idx = now - signal_start_[s];
                    e->set_source_force(s, idx < signals_[s].size() ? signals_[s][idx] : 0.0);
                }
                e->step();
                for (std::size_t r = 0; r < traces_.size(); ++r)
                    traces_[r].push_back(e->receiver_value(r));
            }
        },
        engine_);
}

std::vector<double> Simulation::snapshot() const
{
    return std::visit([](auto &e) { return e->displacement(); }, engine_);
}

double Simulation::energy() const
{
    return std::visit([](auto &e) { return e->energy(); }, engine_);
}

}  // namespace calib::engine
