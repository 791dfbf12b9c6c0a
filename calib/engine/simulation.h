// The engine's public face for the pipeline: one plate, N point
// sources with per-step force signals, M receivers, run for a number of steps
// or seconds, read traces, snapshots and energy. Precision is chosen at run
// time; the engine underneath is compiled for float and double.
//
// Non-finite values are caught at once and never reach a trace: source forces
// before each step, receivers after each step, the whole field every
// `field_check_interval` steps and at the end of every run(). The first one
// throws std::runtime_error naming the step, the time and where (source,
// receiver, node (i, j) and position); the simulation then refuses to run on.
// Step n is the update from t = n k to t = (n + 1) k; its output is
// traces()[r][n].
//
// Engines (chosen once, in the constructor; each run() is one loop compiled
// for its engine, so the Kirchhoff path pays nothing for the others):
// the Kirchhoff PlateEngine<float> or <double>, or, with
// SimulationOptions::thick_plate, the Mindlin engine
// (engine/mindlin/mindlin_engine.h; double only, its own stability bound).
// Both offer the same members to run() and the point interface to the
// effects (point_field.h). Effects composed per simulation: the finger
// (add_finger()).
#pragma once

#include "engine/effects/effects.h"
#include "engine/plate_engine.h"
#include "engine/plate_operator.h"

#include <cstddef>
#include <functional>
#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace calib::engine {

namespace mindlin {
class MindlinOperator;
class MindlinEngine;
} // namespace mindlin

enum class Precision { f32, f64 };
const char *precision_name(Precision p);

struct SimulationOptions {
    Precision precision = Precision::f32;
    double courant = 0.95;  // fraction of the stability bound used when time_step_s == 0
    double time_step_s = 0; // forced step; refused if not below the bound
    // Whole-field NaN/Inf scan every this many steps (and at the end of every
    // run()); 0 scans only at the end of run(). Cheap: an integer test of the
    // exponent bits, measured in docs/engine.md ("Stability suite").
    std::size_t field_check_interval = 16;
    EngineOptions engine;
    // Thick-plate effect: run the Mindlin engine on the operator's plate
    // params and grid instead of Kirchhoff. Double precision whatever
    // `precision` says (precision() then reports f64); time step = courant x
    // the Mindlin bound (or time_step_s, checked against it); edges supported
    // or clamped only, no loss (the constructor throws otherwise).
    bool thick_plate = false;
    // The Mindlin operator of this plate (assembly and Lanczos bound, the
    // costly part): scene::build_plate makes it once for a thick-plate scene
    // and every simulation made with these options shares it. Left empty, a
    // thick-plate simulation builds its own.
    std::shared_ptr<const mindlin::MindlinOperator> thick_plate_operator;
};

// Throws std::invalid_argument if k is not below the stability bound of the
// assembled operator. With loss, the message names the loss when it is what
// breaks the bound (the step would be stable without it).
void check_stable_time_step(const PlateOperator &op, double k);
// The Kirchhoff engine's time step for these options: time_step_s (checked
// against the bound) or courant x the bound.
double kirchhoff_time_step(const PlateOperator &op, const SimulationOptions &options);

class Simulation {
  public:
    Simulation(std::shared_ptr<const PlateOperator> op, const SimulationOptions &options);
    ~Simulation();
    Simulation(Simulation &&) noexcept;
    Simulation &operator=(Simulation &&) noexcept;

    bool thick_plate() const { return options_.thick_plate; }

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
    // The finger effect (effects.h): a mass-spring-damper on the plate at its
    // point, coupled exactly each step (finger.h). Throws std::invalid_argument
    // off the plate or for a spring the time step cannot take.
    std::size_t add_finger(const effects::FingerSpec &spec);
    // finger_forces()[f][n]: force (N) finger f put on the plate in step n.
    const std::vector<std::vector<double>> &finger_forces() const { return finger_forces_; }

    // Advances `steps` steps and appends one sample per step to every trace.
    // Throws std::runtime_error on a non-finite force or displacement (see
    // above); the traces then hold only the finite samples before it.
    void run(std::size_t steps);
    // Steps needed to cover `duration_s` (rounded up).
    std::size_t steps_for(double duration_s) const;

    // traces()[r][n]: displacement (m) of receiver r after step n.
    const std::vector<std::vector<double>> &traces() const { return traces_; }
    std::vector<double> snapshot() const; // node grid, row-major (j, i)
    // Decimated whole-field recording: w at every `stride`-th node of both axes
    // (from node (0, 0)), after step `first_step` and every `interval` steps
    // after it, appended to lattice_frames() ([frame][point], row-major). A copy
    // of the lattice every `interval` steps instead of per-step receivers.
    void record_lattice(int stride, std::size_t first_step, std::size_t interval);
    const std::vector<float> &lattice_frames() const { return lattice_frames_; }
    // Hands over the frames recorded so far in `out` and goes on recording
    // into out's former buffer, emptied (a long recording read in chunks holds
    // two chunks, and reuses their memory).
    void take_lattice_frames(std::vector<float> &out)
    {
        out.clear();
        out.swap(lattice_frames_);
    }
    double energy() const; // the plate's (J); a finger's own energy is not included

  private:
    std::shared_ptr<const PlateOperator> op_;
    SimulationOptions options_;
    double k_ = 0;
    std::variant<std::unique_ptr<PlateEngine<float>>, std::unique_ptr<PlateEngine<double>>,
                 std::unique_ptr<mindlin::MindlinEngine>>
        engine_;
    std::vector<std::function<double()>> finger_force_; // reads the last step's force of each finger
    std::vector<std::vector<double>> finger_forces_;
    std::vector<std::vector<double>> signals_;
    std::vector<std::size_t> signal_start_;
    std::vector<std::vector<double>> traces_;
    int lattice_stride_ = 0;
    std::size_t lattice_first_ = 0, lattice_interval_ = 1;
    std::vector<float> lattice_frames_;
    std::size_t last_clean_scan_ = 0; // steps_done() at the last whole-field scan that found nothing
    std::string failure_;             // set once a non-finite value was found
};

} // namespace calib::engine
