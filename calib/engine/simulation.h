// The engine's public face for the pipeline (issue #4): one plate, N point
// sources with per-step force signals, M receivers, run for a number of steps
// or seconds, read traces, snapshots and energy. Precision is chosen at run
// time; the engine underneath is compiled for float and double.
#pragma once

#include "engine/plate_engine.h"
#include "engine/plate_operator.h"

#include <cstddef>
#include <memory>
#include <variant>
#include <vector>

namespace calib::engine {

enum class Precision { f32, f64 };
const char *precision_name(Precision p);

struct SimulationOptions {
    Precision precision = Precision::f32;
    double courant = 0.95;    // fraction of the stability bound used when time_step_s == 0
    double time_step_s = 0;   // forced step; refused if not below the bound
    EngineOptions engine;
};

class Simulation {
public:
    Simulation(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options);

    const PlateOperator &plate() const { return *op_; }
    double time_step_s() const { return k_; }
    Precision precision() const { return options_.precision; }
    std::size_t steps_done() const;
    double time_s() const { return double(steps_done()) * k_; }

    std::size_t add_source(double x_m, double y_m);
    std::size_t add_receiver(double x_m, double y_m);
    // force_n[n] (N) acts during step n counted from the first run() after
    // this call; zero after the signal ends.
    void set_source_signal(std::size_t source, std::vector<double> force_n);
    // A unit impulse (1 N s) in the first step: force 1/k during one step.
    void set_source_impulse(std::size_t source);

    // Advances `steps` steps and appends one sample per step to every trace.
    void run(std::size_t steps);
    // Steps needed to cover `duration_s` (rounded up).
    std::size_t steps_for(double duration_s) const;

    // traces()[r][n]: displacement (m) of receiver r after step n.
    const std::vector<std::vector<double>> &traces() const { return traces_; }
    std::vector<double> snapshot() const;  // node grid, row-major (j, i)
    double energy() const;

private:
    std::shared_ptr<const PlateOperator> op_;
    SimulationOptions options_;
    double k_ = 0;
    std::variant<std::unique_ptr<PlateEngine<float>>, std::unique_ptr<PlateEngine<double>>> engine_;
    std::vector<std::vector<double>> signals_;
    std::vector<std::size_t> signal_start_;
    std::vector<std::vector<double>> traces_;
};

}  // namespace calib::engine
