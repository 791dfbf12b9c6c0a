#include "model/resources.h"

#include "engine/modes.h"
#include "engine/spectrum.h"
#include "model/error_model.h"
#include "physics/dispersion.h"
#include "pipeline/placement/focus_subset.h"
#include "pipeline/placement/placement.h"
#include "pipeline/plan.h"
#include "pipeline/placement/site_recording.h"
#include "pipeline/signal/pulse.h"
#include "io/format.h"

#include <omp.h>

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace calib::model {

namespace {

using io::fmt;

// A /proc/self/status field in kB, as MB.
double status_mb(const std::string &key)
{
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0)
            return std::strtod(line.c_str() + key.size(), nullptr) / 1024.0;
    return 0;
}

} // namespace

Limits machine_limits(std::optional<double> max_memory_mb, std::optional<double> max_seconds)
{
    Limits l;
    if (max_memory_mb) {
        if (!(*max_memory_mb > 0) || !std::isfinite(*max_memory_mb))
            throw std::invalid_argument("--max-memory: must be a positive number of MB");
        l.memory_mb = *max_memory_mb;
        l.memory_source = "--max-memory";
    } else {
        const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
        l.memory_mb = pages > 0 && page > 0 ? double(pages) * double(page) / (1024.0 * 1024.0) : INFINITY;
        l.memory_source = "physical memory; --max-memory sets it";
    }
    if (max_seconds) {
        if (!(*max_seconds > 0))
            throw std::invalid_argument("--max-seconds: must be a positive number of seconds");
        l.seconds = *max_seconds;
    }
    return l;
}

void refuse_if_over(const std::string &what, double memory_mb, double seconds, const Limits &limits,
                    const std::string &cause_key)
{
    const bool memory = !(memory_mb <= limits.memory_mb);
    const bool time = limits.seconds && !(seconds <= *limits.seconds);
    if (!memory && !time)
        return;
    std::string limit =
        memory ? "over this machine's " + fmt("%.0f MB", limits.memory_mb) + " (" + limits.memory_source + ")"
               : "over the time limit of " + fmt("%g s", *limits.seconds) + " (--max-seconds)";
    throw std::runtime_error(what + ": refused before simulating: predicted " + fmt("%.0f MB", memory_mb) +
                             " peak memory and " + fmt("%.3g s", seconds) + ", " + limit + "; " + cause_key);
}

std::string calibration_cause(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan,
                              const Prediction &p, bool verification_only)
{
    if (!verification_only && p.traces_mb + p.recordings_mb >= p.fields_mb) {
        const std::string sites = fmt("%.0f", double(plan.sites.size())) + " candidate sites x " +
                                  fmt("%.0f", std::ceil(double(plan.window_steps) / double(plan.site_decimation))) +
                                  " samples of recordings";
        if (in.exciters.site_spacing_m)
            return sites + ": raise exciters.site_spacing_m (" + fmt("%g m", *in.exciters.site_spacing_m) +
                   ") or shorten calibration.window_s";
        return sites + " (sites lambda/8 = " + fmt("%.3g mm", plan.site_spacing_m * 1e3) +
               " apart): lower pulse.centre_hz (" + fmt("%g Hz", in.pulse.centre_hz) +
               ") or set exciters.site_spacing_m";
    }
    const engine::Grid &g = in.plate->grid();
    return fmt("%.0f", double(plan.window_steps)) + " steps per window on a grid of " + std::to_string(g.nx) + " x " +
           std::to_string(g.ny) + " cells of " + fmt("%.3g mm", g.h * 1e3) +
           ": lower simulation.points_per_wavelength or simulation.f_max_hz";
}

Priced refuse_unaffordable(const pipeline::CalibrationInput &in, const Limits &limits, const std::string &what,
                           bool verification_only)
{
    Priced r{pipeline::plan(in), {}};
    auto price = [&](const CostModel *c) {
        return verification_only ? predict_verification(in, r.plan, c) : predict(in, r.plan, c);
    };
    r.prediction = price(nullptr);
    if (r.prediction.memory_mb <= limits.memory_mb && !limits.seconds)
        return r;
    // A time for the message, or for the limit: a reduced timing of the
    // scene's operator (its fields fit, or the memory test would not have
    // passed the grid check in build_plate).
    const CostModel cost = measure_cost(in, r.plan, 2e6);
    r.prediction = price(&cost);
    refuse_if_over(what, r.prediction.memory_mb, r.prediction.seconds, limits,
                   calibration_cause(in, r.plan, r.prediction, verification_only));
    return r;
}

namespace {

// Seconds per node-step of the float engine on one core, on a small plate
// (the fastest of three runs): what every grid costs at least per node.
double small_plate_seconds_per_node_step()
{
    engine::PlateParams params;
    params.size_x_m = params.size_y_m = 0.3;
    params.thickness_m = 0.002;
    params.material = *physics::find_material("acrylic");
    engine::Grid g;
    g.nx = g.ny = 100;
    g.h = 0.003;
    auto op = std::make_shared<const engine::PlateOperator>(params, g);
    engine::SimulationOptions so;
    so.time_step_s = 0.5 * g.h * g.h / (4 * op->kappa()); // well inside the interior bound
    so.engine.skip_stability_check = true;
    return measure_seconds_per_step(op, so, 1, 1e6) / double(g.node_count());
}

} // namespace

void refuse_before_build(const scene::Scene &s, const Limits &limits, bool calibration, double duration_s,
                         std::size_t receivers)
{
    const scene::PlateSpec &pl = s.plate;
    const double kappa = pl.material.kappa(pl.thickness_m);
    const engine::Grid g = scene::plate_grid(s); // refuses absurd grids, naming the cell count and the key
    const double nodes = double(g.nx + 1) * double(g.ny + 1);
    const double courant = s.simulation.courant > 0 && s.simulation.courant < 1 ? s.simulation.courant : 1.0;
    const double k = s.simulation.time_step_s ? *s.simulation.time_step_s : courant * g.h * g.h / (4 * kappa);
    const double mb = 1024.0 * 1024.0;
    const engine::Precision prec = s.effects.thick_plate ? engine::Precision::f64 : s.simulation.precision;
    // Building the plate peaks at its operator's assembly (the triplets next to
    // the finished matrices), whatever runs on it after; a simulation on
    // clamped and supported edges assembles no matrix (its engine steps the
    // mirrored stencil), only the unknowns' maps and masses.
    // (Three 8-byte values per node: unknown index, node index, mass; rounded up.)
    const bool any_free = !pl.edges.none_free();
    const double operator_bytes = !calibration && !any_free && !s.effects.thick_plate
                                      ? 32.0 * nodes
                                      : engine::plate_operator_bytes(std::size_t(nodes));
    double memory_mb = current_rss_mb() + operator_bytes / mb, node_steps = 0;
    double output_seconds = 0;
    std::string cause;
    if (!calibration) {
        const double steps = std::ceil(duration_s / k);
        memory_mb += (simulation_bytes(std::size_t(nodes), prec, 0, 0) + double(receivers) * steps * 8) / mb;
        node_steps = nodes * steps;
        // The CSV after the run: a row per step, a formatted number per
        // column (measured: 25.8M rows of two columns in 13 s of processor
        // time, 0.25 us a number), which a short run on a tiny step makes most
        // of the time.
        constexpr double csv_seconds_per_number = 0.3e-6;
        output_seconds = steps * double(1 + receivers) * csv_seconds_per_number;
        cause = fmt("%.3g", steps) + " steps of " + fmt("%.3g s", k) + " on a grid of " + std::to_string(g.nx) + " x " +
                std::to_string(g.ny) +
                " cells: shorten --duration, or lower simulation.points_per_wavelength or "
                "simulation.f_max_hz";
    } else {
        if (!s.calibration_sections())
            return;
        const double window_steps = std::ceil(s.calibration->window_s / k);
        const double lambda = physics::kirchhoff_wavelength_m(kappa, s.pulse->centre_hz);
        pipeline::Band band;
        band.plate_x_m = pl.size_x_m;
        band.plate_y_m = pl.size_y_m;
        band.frame_margin_m = s.active_area->frame_margin_m;
        band.active_area = s.active_area->area;
        band.clearance_m = s.active_area->clearance_m;
        const bool fixed = s.exciters->placement == pipeline::PlacementMode::fixed;
        const double spacing = s.exciters->site_spacing_m.value_or(lambda / 8);
        if (!fixed && !(pipeline::lattice_points(band, spacing) <= pipeline::max_candidate_sites))
            return; // plan() refuses it, naming the key, before enumerating anything
        const double sites =
            fixed ? double(s.exciters->positions.size()) : double(pipeline::candidate_sites(band, spacing).size());
        const double threads = std::max(1, omp_get_max_threads());
        const double rate = pipeline::search_rate(*s.pulse);
        // The placement simulates the foci of its subset only (pipeline/placement/focus_subset.h).
        const double foci = std::min(
            double(s.foci->points.size()),
            double(pipeline::placement_focus_cap(
                s.exciters->placement_foci, sites,
                pipeline::contrast_model_lags(s.calibration->window_s, s.calibration->truncate_fraction, rate))));
        // Each running reciprocity simulation: a double per site and recorded
        // sample, and two chunks of field copies (pipeline/placement/site_recording.h).
        const double decimation = double(pipeline::site_recording_options(k, rate).decimation);
        const double traces = std::min(threads, foci) *
                              (sites * std::ceil(window_steps / decimation) * 8 +
                               2.0 * double(pipeline::site_recording_chunk_frames) * nodes * 4) /
                              mb;
        const double recordings = 2 * foci * sites * s.calibration->window_s * rate * 4 / mb;
        const double fields = std::min(threads, foci) * simulation_bytes(std::size_t(nodes), prec, 0, 0) / mb;
        memory_mb += traces + recordings + fields;
        node_steps = nodes * window_steps * std::ceil(foci / threads);
        if (traces + recordings >= fields) {
            cause = fmt("%.0f", sites) + " candidate sites x " + fmt("%.0f", std::ceil(window_steps / decimation)) +
                    " samples of recordings";
            cause +=
                s.exciters->site_spacing_m
                    ? ": raise exciters.site_spacing_m (" + fmt("%g m", spacing) + ") or shorten calibration.window_s"
                    : " (sites lambda/8 = " + fmt("%.3g mm", spacing * 1e3) + " apart): lower pulse.centre_hz (" +
                          fmt("%g Hz", s.pulse->centre_hz) + ") or set exciters.site_spacing_m";
        } else {
            cause = fmt("%.0f", window_steps) + " steps per window on a grid of " + std::to_string(g.nx) + " x " +
                    std::to_string(g.ny) + " cells: lower simulation.points_per_wavelength or simulation.f_max_hz";
        }
    }
    const bool over_memory = !(memory_mb <= limits.memory_mb);
    if (!over_memory && !limits.seconds)
        return;
    // Building the plate comes first: its operator and the stability bound. With
    // a free edge that is a Lanczos run on the stiffness and one on the
    // edge-band operator (up to lanczos_max_iterations sparse products each); a
    // product of the 13-point CSR matrix costs about 8 stencil updates per row
    // (measured: 16 s for the two runs on 1424 x 1187 cells, against 3.9 ms per
    // time step), so on a fine grid with a short run the set-up is most of the
    // time. Clamped and supported edges need none (the interior bound is
    // proven there: engine/plate_operator.cpp).
    const double setup_node_steps = any_free ? nodes * 2.0 * engine::lanczos_max_iterations * 8.0 : 0.0;
    const double seconds = (node_steps + setup_node_steps) * small_plate_seconds_per_node_step() + output_seconds;
    refuse_if_over(s.file, memory_mb, seconds, limits, cause);
}

double current_rss_mb() { return status_mb("VmRSS:"); }

double peak_rss_mb() { return status_mb("VmHWM:"); }

void reset_peak_rss()
{
    malloc_trim(0); // hand freed heap back, so the peak counts what the next run needs
    std::ofstream f("/proc/self/clear_refs");
    f << "5"; // resets VmHWM (Linux >= 4.0)
}

} // namespace calib::model
