// What a calibration (or one simulation) costs in time and memory, priced
// from the plan the pipeline executes (pipeline/plan.h) and a quick timing of
// the scene's own operator on this machine. docs/ACCURACY.md compares it
// with measurement.
#pragma once
#include "engine/plate_operator.h"
#include "engine/simulation.h"
#include "pipeline/calibrate.h"
#include "pipeline/design/inverse_filter_cost.h"
#include "pipeline/plan.h"

#include <cstddef>
#include <memory>
#include <optional>

namespace calib::model {

// Seconds per step of one simulation on one core, timed on the scene's own
// operator with the recording and sources each pipeline stage uses: the
// reciprocity simulations copy the field every plan.site_decimation steps
// (pipeline/placement/site_recording.h), the verification drives the exciters and
// records the foci. The fastest of three runs of
// about `node_steps` node-steps each (a shared machine only ever slows it down).
struct CostModel {
    engine::Precision precision = engine::Precision::f32;
    double seconds_per_step_simulate = 0;
    double seconds_per_step_verify = 0;
    double seconds_per_node_step = 0; // the simulate figure per node, for reports
    double seconds_per_resample = 0;  // soxr of one site's recording (the window, decimated) to the search rate
    int threads = 1;                  // simulations that run at once (one core each)
    // The inverse filter's designs (method = "inverse_filter" with the
    // transfer matrix; zero otherwise), timed on one core on the scene's shape
    // (pipeline/design/inverse_filter.h); `plain_design` for a robust scene's
    // plain design, which it also makes and verifies.
    pipeline::InverseFilterSeconds design, plain_design;
};
// The shape of the scene's inverse-filter designs (nominal plate and robust
// members), from the plan's transfer matrix; nullopt when the scene designs
// by time reversal or has no transfer matrix.
std::optional<pipeline::InverseFilterShape> inverse_filter_shape(const pipeline::CalibrationInput &in,
                                                                 const pipeline::CalibrationPlan &plan);
CostModel measure_cost(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan,
                       double node_steps = 1.5e7);

// Seconds per step of one simulation with `receivers` receivers and one
// source, timed the same way (for `calibgen simulate`).
double measure_seconds_per_step(const std::shared_ptr<const engine::PlateOperator> &plate,
                                const engine::SimulationOptions &options, std::size_t receivers, double node_steps);

// Bytes one simulation holds while it runs: its field (three levels) and its
// traces (a double per receiver per step).
double simulation_bytes(std::size_t nodes, engine::Precision p, std::size_t receivers, std::size_t steps);
// Bytes a reciprocity simulation records beside its field: a double per site
// per recorded sample, and the field copies of two chunks (pipeline/placement/site_recording.h).
double reciprocity_recording_bytes(const pipeline::CalibrationPlan &plan);

struct Prediction {
    double seconds = 0; // wall time of calibrate(): simulations and verification
    double simulate_s = 0, verify_s = 0;
    double memory_mb = 0;      // peak resident memory, the process's current one included
    double fields_mb = 0;      // the running simulations' fields (three levels each)
    double traces_mb = 0;      // the running simulations' traces
    double recordings_mb = 0;  // the stored recordings (pulse and impulse responses)
    double verdict_probes = 0; // ghost probes the search by the verdict may add (pipeline/placement_verdict.h)
    double design_s = 0;       // the inverse filter's designs (in `seconds`; every placement the verdict judges)
    double design_mb = 0;      // their memory (in `memory_mb`)
};
// Whether the placement search is judged by the verdict
// (pipeline::judged_by_verdict), decided from the scene before anything runs.
bool searched_by_verdict(const pipeline::CalibrationInput &in);

// Memory needs no timing: `cost` may be null, then seconds stay 0.
Prediction predict(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan, const CostModel *cost);
// `calibgen verify`: the plan's last verification pass alone (no recordings).
Prediction predict_verification(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan,
                                const CostModel *cost);

} // namespace calib::model
