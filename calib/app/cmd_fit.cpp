// `calibgen fit SCENE MEASUREMENTS.toml -o FITTED.toml [--report DIR]`: the
// bench step's fit (docs/bench.md). Deconvolves each exciter -> sensor
// response from the recording, simulates the same responses on the scene's
// plate (pipeline/bench/bench_model.h, on a grid fine enough that its own
// dispersion stays below the fit's resolution), fits the speed ratio, the
// loss, each exciter's position and force gain (and each uncalibrated
// sensor's gain) with Ceres, and writes the scene with the fitted values.
#include "app/commands.h"
#include "app/progress.h"
#include "io/atomic_file.h"
#include "io/format.h"
#include "io/read_file.h"
#include "pipeline/bench/bench_fit.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/signal/deconvolve.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/signal/resample.h"
#include "report/bench_report.h"
#include "scene/calibration_input.h"
#include "scene/fitted_scene.h"
#include "scene/measurements.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::app {

namespace {

using io::fmt;

struct FitArgs {
    std::string scene, measurements, output, report;
    double radius_mm = 10, window_ms = 0, model_ppw = 20;
    bool no_loss = false, no_positions = false, no_gains = false, quiet = false;
    bool try_edges = false; // fit on each uniform edge condition too, keep the best
};

// The measured responses at the model's rate, filtered as the model's are.
pipeline::BenchMeasured measured_responses(const scene::Measurements &m, const pipeline::BenchModel &model)
{
    pipeline::BenchMeasured out;
    const std::size_t S = m.sensors.size(), E = m.exciters.size();
    const std::size_t ir = static_cast<std::size_t>(std::floor(m.gap_s * m.rate_hz));
    out.responses.resize(S);
    for (std::size_t s = 0; s < S; s++) {
        const scene::MeasuredSensor &sensor = m.sensors[s];
        const double u = sensor.units_per_count.value_or(1.0);
        for (std::size_t e = 0; e < E; e++) {
            const std::vector<double> rec = m.segment(s, e), x = m.excitation(e);
            std::vector<double> h =
                pipeline::impulse_response(rec.data(), rec.size(), x.data(), x.size(), std::min(ir, rec.size()),
                                           m.sweep_f1_hz, m.sweep_f2_hz, m.rate_hz);
            for (double &v : h) // per unit of normalised drive per second, in the sensor's SI unit
                v *= m.rate_hz * u;
            out.responses[s].push_back(model.band(pipeline::resample(h, m.rate_hz, model.rate_hz()), 0));
        }
        out.sensor_gain_known.push_back(sensor.units_per_count.has_value());
    }
    return out;
}

int run_fit(const FitArgs &a)
{
    const std::optional<std::string> bytes = io::read_file(a.scene);
    if (!bytes)
        throw std::runtime_error(a.scene + ": cannot open scene file");
    scene::Scene s = scene::parse_scene(*bytes, a.scene);
    if (!s.calibration_sections())
        throw std::runtime_error(a.scene + ": not a calibration scene");
    const scene::Measurements m = scene::load_measurements(a.measurements, s);
    pipeline::BenchSetup setup;
    for (const scene::MeasuredSensor &sensor : m.sensors)
        setup.sensors.push_back({sensor.at, sensor.quantity});
    setup.exciters = m.exciters;
    setup.force_full_scale_n = m.force_full_scale_n;
    setup.radius_m = a.radius_mm * 1e-3;
    // The fit band: the pulse's, inside the sweep's by a third of an octave
    // (where the deconvolution's taper is flat).
    const double third = std::pow(2.0, 1.0 / 3.0);
    setup.f_lo_hz = std::max(m.sweep_f1_hz * third, 0.4 * s.pulse->centre_hz);
    setup.f_hi_hz = std::min(m.sweep_f2_hz / third, pipeline::pulse_max_frequency_hz(*s.pulse));
    if (!(setup.f_hi_hz > setup.f_lo_hz))
        throw std::runtime_error(a.measurements + ": excitation.sweep_hz: the sweep does not cover the pulse's band");
    setup.window_s = a.window_ms > 0 ? a.window_ms * 1e-3 : std::min(0.12, 0.6 * m.gap_s);
    Progress progress(a.quiet);
    const pipeline::ProgressFn report_progress = progress.callback();
    pipeline::BenchFitOptions opt;
    opt.loss = !a.no_loss;
    opt.positions = !a.no_positions;
    opt.gains = !a.no_gains;
    opt.progress = [&](const std::string &stage, unsigned done, unsigned total) {
        report_progress(stage, done, total);
    };
    // The model's plate: the scene's, on a grid of at least model_ppw points
    // per wavelength at the scene's highest frequency, so that the fitted
    // speed ratio is the panel's and not the scene grid's dispersion.
    struct Candidate {
        std::optional<engine::EdgeKind> edges; // unset: the scene's
        std::unique_ptr<pipeline::BenchModel> model;
        pipeline::BenchFitResult fit;
        engine::Grid grid;
    };
    std::vector<Candidate> candidates(1);
    pipeline::BenchMeasured measured;
    const engine::Edges &e = s.plate.edges;
    const bool uniform = e.left == e.right && e.left == e.bottom && e.left == e.top;
    if (a.try_edges)
        for (engine::EdgeKind k :
             {engine::EdgeKind::clamped, engine::EdgeKind::simply_supported, engine::EdgeKind::free})
            if (!uniform || k != e.left) // the scene's own condition is the first candidate
                candidates.push_back({k, nullptr, {}, {}});
    for (Candidate &c : candidates) {
        scene::Scene fine = s;
        fine.simulation.points_per_wavelength = std::max(s.simulation.points_per_wavelength, a.model_ppw);
        fine.simulation.grid_spacing_m.reset();
        fine.simulation.precision = engine::Precision::f64;
        if (c.edges)
            fine.plate.edges = engine::Edges::all(*c.edges);
        const pipeline::CalibrationInput in = scene::calibration_input(fine, scene::build_plate(fine), *bytes);
        c.grid = in.plate->grid();
        c.model = std::make_unique<pipeline::BenchModel>(in, setup);
        // Deconvolved once: every candidate's model has the same rate, window and band.
        if (measured.responses.empty())
            measured = measured_responses(m, *c.model);
        c.fit = pipeline::fit_bench(*c.model, measured, opt);
    }
    std::size_t best = 0;
    for (std::size_t i = 1; i < candidates.size(); i++)
        if (candidates[i].fit.residual_after_db < candidates[best].fit.residual_after_db)
            best = i;
    const pipeline::BenchModel &model = *candidates[best].model;
    const pipeline::BenchFitResult &r = candidates[best].fit;
    const engine::Grid &grid = candidates[best].grid;

    // The terminal: what was fitted, how well, what to do with it.
    std::ostringstream o;
    o << "fit " << a.measurements << " on " << s.name << ": " << m.sensors.size() << " sensors x " << m.exciters.size()
      << " exciters, band " << fmt("%.0f", setup.f_lo_hz) << "-" << fmt("%.0f", setup.f_hi_hz) << " Hz, window "
      << fmt("%.0f", setup.window_s * 1e3) << " ms, model grid " << grid.nx << " x " << grid.ny << "\n";
    for (const Candidate &c : candidates)
        if (candidates.size() > 1)
            o << "  edges " << (c.edges ? engine::edge_kind_name(*c.edges) : "as the scene's") << ": residual "
              << fmt("%.1f", c.fit.residual_after_db) << " dB fitted" << (&c == &candidates[best] ? " (kept)" : "")
              << "\n";
    o << "  residual (energy of model - measured over measured): " << fmt("%.1f", r.residual_before_db)
      << " dB with the scene's values -> " << fmt("%.1f", r.residual_after_db) << " dB fitted\n";
    o << "  " << fmt("%-26s", "parameter") << fmt("%12s", "scene") << fmt("%12s", "fitted") << fmt("%12s", "+-1 sigma")
      << "\n";
    for (const pipeline::FitParameter &p : r.parameters) {
        o << "  " << fmt("%-26s", p.name.c_str()) << fmt("%12.5g", p.nominal) << fmt("%12.5g", p.value)
          << (p.fitted ? fmt("%12.2g", p.sigma) : std::string(12, ' '));
        if (!p.identifiable)
            o << "  not identifiable";
        if (!p.note.empty())
            o << "  " << p.note;
        o << "\n";
    }
    for (const std::string &n : r.notes)
        o << "  note: " << n << "\n";
    const double eta0 = model.nominal_loss_factor();
    o << "  the panel's response runs " << fmt("%.4f", r.fitted.speed_ratio)
      << " times as fast as the scene's: a board playing a table of this scene sets [panel] speed_ratio = "
      << fmt("%.4f", r.fitted.speed_ratio) << "\n";
    o << "  " << r.iterations << " solver iterations, " << r.simulations << " simulations, " << fmt("%.1f", r.seconds)
      << " s; " << r.solver << "\n";

    scene::FittedValues fv;
    fv.speed_ratio = r.fitted.speed_ratio;
    fv.loss_scale = eta0 > 0 ? r.fitted.loss_factor / eta0 : 1.0;
    fv.exciters = r.fitted.exciters;
    fv.force_gains = r.fitted.gains;
    fv.edges = candidates[best].edges;
    fv.comment = "Fitted by calibgen fit from " + a.measurements + " (" + std::to_string(m.sensors.size()) +
                 " sensors, band " + fmt("%.0f-%.0f Hz", setup.f_lo_hz, setup.f_hi_hz) + ", window " +
                 fmt("%.0f ms", setup.window_s * 1e3) + ") on " + a.scene + ".\n" + "speed ratio " +
                 fmt("%.5f", r.fitted.speed_ratio) + " (E = alpha^2 x the scene's), loss factor " +
                 fmt("%.4f", r.fitted.loss_factor) + " (scene " + fmt("%.4f", eta0) +
                 "; each T60 scaled), exciter positions and force gains below.\n" + "Residual " +
                 fmt("%.1f", r.residual_before_db) + " dB -> " + fmt("%.1f", r.residual_after_db) +
                 " dB. Calibrate this scene for the measured panel." +
                 (fv.edges ? std::string("\nEdges: ") + engine::edge_kind_name(*fv.edges) +
                                 ", the best fit of clamped, simply supported and free."
                           : std::string());
    io::write_file_atomic(a.output, scene::fitted_scene_text(*bytes, s, fv));
    o << "  wrote " << a.output << "\n";
    if (!a.report.empty()) {
        report::write_bench_report(a.report, model, measured, r);
        o << "  report " << a.report << "/index.html\n";
    }
    std::fputs(o.str().c_str(), stdout);
    return 0;
}

} // namespace

void register_fit(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<FitArgs>();
    CLI::App *cmd = app.add_subcommand(
        "fit", "The bench step: fit the scene's plate and exciters to measured responses, write the fitted scene");
    cmd->add_option("scene", a->scene, "Scene file (TOML)")->required();
    cmd->add_option("measurements", a->measurements, "measurements.toml (calibgen measure-plan, filled in)")
        ->required();
    cmd->add_option("-o,--output", a->output, "The fitted scene (TOML)")->required();
    cmd->add_option("--report", a->report, "Directory for the report (index.html, fit.json, response plots)");
    cmd->add_option("--radius-mm", a->radius_mm, "How far an exciter may be from its nominal position (mm)")
        ->check(CLI::Range(0.5, 50.0));
    cmd->add_option("--window-ms", a->window_ms,
                    "Fitted part of each response (ms; default: 120 or 60 % of the plan's silence)")
        ->check(CLI::Range(5.0, 2000.0));
    cmd->add_option("--model-ppw", a->model_ppw,
                    "Points per wavelength of the model's grid at the scene's highest frequency (at least the "
                    "scene's)")
        ->check(CLI::Range(8.0, 60.0));
    cmd->add_flag("--no-loss", a->no_loss, "Hold the loss at the scene's");
    cmd->add_flag("--no-positions", a->no_positions, "Hold the exciters at their nominal positions");
    cmd->add_flag("--no-gains", a->no_gains, "Hold the exciters' force gains at 1");
    cmd->add_flag("--try-edges", a->try_edges,
                  "Fit also on clamped, simply supported and free edges (all four alike) and keep the condition "
                  "that fits best (four fits' time)");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress lines");
    cmd->callback([a, &exit_code] { exit_code = run_fit(*a); });
}

} // namespace calib::app
