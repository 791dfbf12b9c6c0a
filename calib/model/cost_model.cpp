#include "model/cost_model.h"
#include "pipeline/placement_verdict.h"

#include "model/resources.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/placement/site_recording.h"
#include "pipeline/design/time_reversal.h"
#include "pipeline/signal/resample.h"
#include "pipeline/transfer/transfer.h"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace calib::model {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// lattice_interval > 0: also a copy of the whole field every that many steps,
// handed over in chunks, as a reciprocity simulation records (pipeline/placement/site_recording.h).
double time_one(const std::shared_ptr<const engine::PlateOperator> &op, engine::SimulationOptions so,
                std::size_t sources, std::size_t receivers, double node_steps, std::size_t lattice_interval = 0)
{
    so.engine.threads = 1;
    engine::Simulation sim(op, so);
    if (lattice_interval > 0)
        sim.record_lattice(1, 0, lattice_interval);
    const double x = op->params().size_x_m, y = op->params().size_y_m;
    const double work = double(op->grid().node_count()) + 4.0 * double(receivers + sources);
    const auto steps = static_cast<size_t>(std::clamp(node_steps / work, 20.0, 20000.0));
    for (std::size_t s = 0; s < sources; s++)
        sim.set_source_signal(sim.add_source((0.1 + 0.8 * double(s) / double(sources)) * x, 0.05 * y),
                              std::vector<double>(3 * steps + 10, 1e-3));
    for (std::size_t r = 0; r < receivers; r++)
        sim.add_receiver((0.05 + 0.9 * double(r) / double(receivers)) * x, 0.93 * y);
    std::vector<float> frames;
    sim.run(10);            // warm-up
    double best = INFINITY; // the fastest of three: a shared machine only ever slows it down
    for (int rep = 0; rep < 3; rep++) {
        const auto t0 = Clock::now();
        sim.run(steps);
        if (lattice_interval > 0)
            sim.take_lattice_frames(frames);
        best = std::min(best, seconds_since(t0) / double(steps));
    }
    return best;
}

} // namespace

double measure_seconds_per_step(const std::shared_ptr<const engine::PlateOperator> &plate,
                                const engine::SimulationOptions &options, std::size_t receivers, double node_steps)
{
    return time_one(plate, options, 1, receivers, node_steps);
}

CostModel measure_cost(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan, double node_steps)
{
    CostModel c;
    c.precision = in.simulation.precision;
    c.threads = std::max(1, omp_get_max_threads());
    engine::SimulationOptions so = in.simulation;
    so.thick_plate = in.effects.thick_plate;
    // A reciprocity simulation: one source, a field copy every site_decimation
    // steps (a site recording without decimation reads every step's field).
    c.seconds_per_step_simulate = time_one(in.plate, so, 1, 0, node_steps, plan.site_decimation);
    c.seconds_per_step_verify = time_one(in.plate, so, in.exciters.count, in.foci.points.size(), node_steps);
    c.seconds_per_node_step = c.seconds_per_step_simulate / double(plan.nodes);
    // Each site's recording is resampled to the search rate (soxr): timed on
    // one group of traces at the recording rate, as resample_all runs them.
    const double recording_rate = 1.0 / (double(plan.site_decimation) * plan.time_step_s);
    std::vector<double> trace((plan.window_steps + plan.site_decimation - 1) / plan.site_decimation);
    for (size_t n = 0; n < trace.size(); n++)
        trace[n] =
            std::sin(0.01 * double(n * plan.site_decimation)) * std::exp(-1e-4 * double(n * plan.site_decimation));
    const std::vector<std::vector<double>> group(pipeline::resample_group_channels, trace);
    const auto t0 = Clock::now();
    const int reps = 3;
    for (int r = 0; r < reps; r++)
        (void)pipeline::resample_all(group, recording_rate, plan.search_rate_hz);
    c.seconds_per_resample = seconds_since(t0) / double(reps * group.size());
    if (const auto shape = inverse_filter_shape(in, plan)) {
        const pipeline::InverseFilterOptions o = pipeline::scene_inverse_filter_options(in);
        c.design = pipeline::time_inverse_filter(*shape, o);
        if (shape->plates > 1) {
            pipeline::InverseFilterShape plain = *shape;
            plain.plates = 1;
            c.plain_design = pipeline::time_inverse_filter(plain, o);
        }
    }
    return c;
}

std::optional<pipeline::InverseFilterShape> inverse_filter_shape(const pipeline::CalibrationInput &in,
                                                                 const pipeline::CalibrationPlan &plan)
{
    if (in.calibration.method != pipeline::DriveMethod::inverse_filter || !plan.transfer)
        return std::nullopt;
    const pipeline::TransferOptions t = pipeline::transfer_options(in, plan.time_step_s);
    return pipeline::inverse_filter_shape(in, 1.0 / (double(t.decimation) * plan.time_step_s), t.samples,
                                          pipeline::observation_lattice(in, t.lattice_stride));
}

double simulation_bytes(std::size_t nodes, engine::Precision p, std::size_t receivers, std::size_t steps)
{
    const double T = p == engine::Precision::f32 ? 4 : 8;
    return 3 * double(nodes) * T + double(receivers) * double(steps) * 8;
}

double reciprocity_recording_bytes(const pipeline::CalibrationPlan &plan)
{
    const double samples = std::ceil(double(plan.window_steps) / double(plan.site_decimation));
    return double(plan.sites.size()) * samples * 8 +
           2.0 * double(pipeline::site_recording_chunk_frames) * double(plan.nodes) * 4;
}

bool searched_by_verdict(const pipeline::CalibrationInput &in)
{
    return in.exciters.placement == pipeline::PlacementMode::random &&
           in.exciters.criterion == pipeline::PlacementCriterion::contrast && in.exciters.verdict_rounds > 0 &&
           pipeline::transfer_holds(in);
}

Prediction predict(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan, const CostModel *cost)
{
    Prediction p;
    const double P = cost ? cost->threads : std::max(1, omp_get_max_threads());
    const double emitters = double(plan.emitters.size()), sites = double(plan.sites.size());
    const double K = double(in.foci.points.size()); // every focus is verified (the placement weighs a subset)
    // The Mindlin engine is double whatever the scene asks (engine/simulation.h).
    const engine::Precision prec = in.effects.thick_plate ? engine::Precision::f64 : in.simulation.precision;
    // Memory: each running simulation keeps its field and traces; the
    // pipeline stores two float recordings per emitter and site at the search
    // rate (the pulse and the impulse responses) until the signals are made.
    const double running = std::min(P, emitters);
    const double mb = 1024.0 * 1024.0;
    p.fields_mb = running * simulation_bytes(plan.nodes, prec, 0, 0) / mb;
    p.traces_mb = running * reciprocity_recording_bytes(plan) / mb;
    p.recordings_mb = 2 * emitters * sites * in.calibration.window_s * plan.search_rate_hz * 4 / mb;
    // H and the spectra of its points (pipeline/transfer/playback.h), kept through the verification.
    p.recordings_mb = std::max(p.recordings_mb, 3 * plan.transfer_bytes / mb);
    // The verification keeps, per focus, the displacement at every focus
    // (double) over the drive and its tail: K^2 traces, the term that grows
    // fastest with a dense grid.
    const double verification_mb =
        K * K * 8 *
        std::ceil((in.calibration.truncate_fraction * in.calibration.window_s + in.calibration.verify_tail_s) *
                  plan.search_rate_hz) /
        mb;
    if (plan.transfer)
        p.traces_mb += verification_mb;
    // The search by the verdict (pipeline/placement_verdict.h): its probe
    // rows fill the contrast model up to its budget, each probe's recordings
    // are kept like an emitter's, and every placement judged keeps an H.
    double probes = 0, judged = 0;
    if (searched_by_verdict(in)) {
        const double len = in.calibration.window_s * plan.search_rate_hz;
        const double lags = len * (1 + pipeline::kept_fraction(in));
        const double row_bytes = sites * double(plan.foci) * lags * 4;
        probes = std::min(double(in.exciters.verdict_rounds * pipeline::ghosts_per_round),
                          std::max(0.0, pipeline::model_budget_bytes / row_bytes - emitters));
        judged = 2 + in.exciters.verdict_rounds;
        p.verdict_probes = probes;
        p.traces_mb += 2 * verification_mb; // the best, the last searched and the current judgement
        // The transfer cache keeps a channel block per site judged (at most
        // every exciter of every placement judged), and three H are alive at once.
        const double cached_sites = std::min(sites, judged * double(in.exciters.count));
        p.recordings_mb += (probes * row_bytes + 2 * probes * sites * len * 4) / mb +
                           (cached_sites / double(in.exciters.count) + 3) * plan.transfer_bytes / mb;
    }
    // The inverse filter's designs: the shared correlations and playback
    // spectra, and one design per core at once (after the simulations).
    const std::optional<pipeline::InverseFilterShape> shape = inverse_filter_shape(in, plan);
    // A robust design's member plates each bring their H and its playback
    // spectra, as the nominal one (above).
    if (shape)
        p.design_mb = (pipeline::inverse_filter_bytes(*shape, std::size_t(std::min(P, K))) +
                       double(shape->plates - 1) * 3 * plan.transfer_bytes) /
                      mb;
    p.memory_mb = current_rss_mb() + p.fields_mb + p.traces_mb + p.recordings_mb + p.design_mb;
    if (!cost)
        return p;
    if (shape) { // every focus, the foci in parallel; a robust scene also designs the plain drives
        auto stage = [&](const pipeline::InverseFilterSeconds &t) { return (t.shared_s + K * t.per_focus_s) / P; };
        p.design_s = (stage(cost->design) + stage(cost->plain_design)) * std::max(1.0, judged);
    }
    p.simulate_s = (cost->seconds_per_step_simulate * double(plan.site_steps) + sites * cost->seconds_per_resample) *
                   std::ceil((emitters + probes) / P);
    if (judged > 0) // at most every exciter of every placement judged is new to the transfer cache
        p.simulate_s +=
            cost->seconds_per_step_verify * double(plan.transfer_steps) * std::ceil(judged * in.exciters.count / P);
    // Each verification pass runs every focus for the drive; a pass with
    // snapshots re-runs each focus to its focus instant (at most the kept window).
    const double kept_steps = pipeline::kept_window_s(in) / plan.time_step_s;
    double verify_steps = 0;
    for (const pipeline::VerificationPass &pass : plan.verification)
        verify_steps += double(plan.drive_steps) + (pass.snapshots ? kept_steps : 0);
    p.verify_s = cost->seconds_per_step_verify * verify_steps * std::ceil(K / P);
    // The transfer matrix: one simulation per exciter (the convolutions are
    // small beside it: 0.13 s of 1.1 s on Fig. 7, docs/BENCHMARKS.md).
    if (plan.transfer)
        p.verify_s += cost->seconds_per_step_verify * double(plan.transfer_steps) * std::ceil(in.exciters.count / P);
    p.seconds = p.simulate_s + p.verify_s + p.design_s;
    return p;
}

Prediction predict_verification(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan,
                                const CostModel *cost)
{
    Prediction p;
    const double P = cost ? cost->threads : std::max(1, omp_get_max_threads());
    const double K = double(in.foci.points.size());
    const engine::Precision prec = in.effects.thick_plate ? engine::Precision::f64 : in.simulation.precision;
    const double mb = 1024.0 * 1024.0;
    const double running = std::min(P, K);
    // Each running focus: its field and traces; every focus keeps its traces
    // and its |w| snapshot (float per node) until the report is written.
    p.fields_mb = running * simulation_bytes(plan.nodes, prec, 0, 0) / mb + K * double(plan.nodes) * 4 / mb;
    p.traces_mb = K * simulation_bytes(0, prec, in.foci.points.size(), plan.drive_steps) / mb;
    if (plan.transfer)
        p.recordings_mb = 3 * plan.transfer_bytes / mb;
    p.memory_mb = current_rss_mb() + p.fields_mb + p.traces_mb + p.recordings_mb;
    if (!cost)
        return p;
    const double kept_steps = pipeline::kept_window_s(in) / plan.time_step_s;
    p.verify_s = plan.transfer
                     ? cost->seconds_per_step_verify * double(plan.transfer_steps) * std::ceil(in.exciters.count / P)
                     : cost->seconds_per_step_verify * (double(plan.drive_steps) + kept_steps) * std::ceil(K / P);
    p.seconds = p.verify_s;
    return p;
}

} // namespace calib::model
