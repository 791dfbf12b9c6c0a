#include "study/accuracy.h"

#include "scene/calibration_input.h"

#include "engine/plate_engine.h"
#include "io/atomic_file.h"
#include "physics/dispersion.h"
#include "pipeline/calibrate.h"
#include "pipeline/time_reversal.h"
#include "report/plot.h"

#include <malloc.h>
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace calib::study {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double pi = std::numbers::pi;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string fmt(const char *f, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

// Kirchhoff A0 wavelength at f: the length scene.cpp divides by points_per_wavelength.
double kirchhoff_wavelength(double kappa, double f_hz) { return 2 * pi * std::sqrt(kappa / (2 * pi * f_hz)); }

struct Ring {
    double beta = 0;   // wavenumber of the mode (rad/m)
    double omega = 0;  // fitted angular frequency (rad/s)
};

template <typename T>
Ring ring_mode(const physics::Material &m, double thickness_m, double h, int nx, double courant)
{
    const int ny = 8 * nx;
    engine::PlateParams params;
    params.size_x_m = nx * h;
    params.size_y_m = ny * h;
    params.thickness_m = thickness_m;
    params.material = m;
    params.edges = engine::Edges::all(engine::EdgeKind::simply_supported);
    engine::Grid g;
    g.nx = nx;
    g.ny = ny;
    g.h = h;
    auto op = std::make_shared<const engine::PlateOperator>(params, g);
    // On a simply supported plate the discrete modes are sines with
    // eigenvalues 16 kappa^2 / h^4 (sin^2 + sin^2)^2 < 64 kappa^2 / h^4, so the
    // interior bound h^2 / (4 kappa) is the operator's (no eigensolver needed).
    const double k = courant * h * h / (4 * op->kappa());
    engine::EngineOptions eo;
    eo.threads = 1;
    eo.skip_stability_check = true;  // guaranteed by the bound above
    engine::PlateEngine<T> eng(op, k, eo);
    const double lx = nx * h, ly = ny * h;
    std::vector<double> phi(g.node_count());
    for (int j = 0; j <= ny; j++)
        for (int i = 0; i <= nx; i++)
            phi[g.node(i, j)] = std::sin(2 * pi * i * h / lx) * std::sin(pi * j * h / ly);
    eng.set_state(phi, phi);
    eng.add_receiver(lx / 4, ly / 2);
    Ring r;
    r.beta = std::hypot(2 * pi / lx, pi / ly);
    const double omega_guess = op->kappa() * r.beta * r.beta;
    const double steps_per_period = 2 * pi / (omega_guess * k);
    // The fit is exact for a single mode; 10 periods average the rounding.
    const auto steps = static_cast<size_t>(std::clamp(10 * steps_per_period, 400.0, 2e5));
    std::vector<double> u;
    u.reserve(steps + 1);
    u.push_back(eng.receiver_value(0));
    for (size_t n = 0; n < steps; n++) {  // a lossless mode: no denormals to flush
        eng.step();
        u.push_back(eng.receiver_value(0));
    }
    // A single discrete mode obeys u[n+1] + u[n-1] = 2 cos(omega k) u[n].
    double num = 0, den = 0;
    for (size_t n = 1; n + 1 < u.size(); n++) {
        num += u[n] * (u[n + 1] + u[n - 1]);
        den += 2 * u[n] * u[n];
    }
    r.omega = std::acos(std::clamp(num / den, -1.0, 1.0)) / k;
    return r;
}

void require_material(const physics::Material &m, double thickness_m, double f_hz)
{
    if (!(thickness_m > 0) || !(f_hz > 0) || !(m.kappa(thickness_m) > 0))
        throw std::invalid_argument("accuracy: needs a positive thickness, frequency and bending stiffness");
}

std::string read_status_field(const char *key)
{
    std::ifstream in("/proc/self/status");
    std::string line;
    while (std::getline(in, line))
        if (line.rfind(key, 0) == 0)
            return line.substr(std::string(key).size());
    return {};
}

double status_mb(const char *key)
{
    const std::string v = read_status_field(key);
    return v.empty() ? 0.0 : std::strtod(v.c_str(), nullptr) / 1024.0;  // kB
}

struct Point2 {
    double x = 0, y = 0;
};

// The largest |w| node, refined by a parabola through it and its two
// neighbours along each axis (sub-cell position of the focal peak).
Point2 snapshot_peak(const std::vector<float> &snap, int nx, int ny, double h)
{
    const size_t cols = size_t(nx) + 1;
    const auto best = static_cast<size_t>(std::max_element(snap.begin(), snap.end()) - snap.begin());
    const int i = int(best % cols), j = int(best / cols);
    auto at = [&](int a, int b) { return double(snap[size_t(b) * cols + size_t(a)]); };
    auto vertex = [](double m, double c, double p) {
        const double den = m - 2 * c + p;
        return den < 0 ? std::clamp(0.5 * (m - p) / den, -0.5, 0.5) : 0.0;
    };
    const double di = (i > 0 && i < nx) ? vertex(at(i - 1, j), at(i, j), at(i + 1, j)) : 0.0;
    const double dj = (j > 0 && j < ny) ? vertex(at(i, j - 1), at(i, j), at(i, j + 1)) : 0.0;
    return {(i + di) * h, (j + dj) * h};
}

double scene_f_max(const scene::Scene &s)
{
    if (s.simulation.f_max_hz > 0)
        return s.simulation.f_max_hz;
    if (s.pulse)
        return pipeline::pulse_max_frequency_hz(*s.pulse);
    throw std::invalid_argument(s.file + ": simulation.f_max_hz: needed for an accuracy target");
}

}  // namespace

const char *model_name(PlateModel m) { return m == PlateModel::kirchhoff ? "kirchhoff" : "mindlin"; }

// Hook for issue #6 part 3: true once calib/engine/effects provides the
// thick-plate (Mindlin) effect and the study can switch it on.
bool model_available(PlateModel m) { return m == PlateModel::kirchhoff; }

PhaseMeasurement measure_phase_velocity(const physics::Material &m, double thickness_m, double f_hz,
                                        const DispersionSetting &s)
{
    require_material(m, thickness_m, f_hz);
    if (!model_available(s.model))
        throw std::invalid_argument(std::string("accuracy: plate model ") + model_name(s.model) +
                                    " is not available in this build");
    if (!(s.points_per_wavelength >= 4) || !(s.courant > 0 && s.courant < 1))
        throw std::invalid_argument("accuracy: points per wavelength must be >= 4 and the Courant factor in (0, 1)");
    const auto t0 = Clock::now();
    PhaseMeasurement pm;
    pm.f_hz = f_hz;
    pm.h_m = kirchhoff_wavelength(m.kappa(thickness_m), f_hz) / s.points_per_wavelength;
    pm.exact_m_s = physics::a0_phase_velocity(m, thickness_m, f_hz);
    const double lambda_exact = pm.exact_m_s / f_hz;
    // Mode (2, 1): x wavelength = nx h; bracket the exact wavelength.
    const int na = std::max(4, static_cast<int>(std::floor(lambda_exact / pm.h_m)));
    auto ring = [&](int nx) {
        return s.precision == engine::Precision::f32 ? ring_mode<float>(m, thickness_m, pm.h_m, nx, s.courant)
                                                     : ring_mode<double>(m, thickness_m, pm.h_m, nx, s.courant);
    };
    const Ring a = ring(na), b = ring(na + 1);
    const double w = 2 * pi * f_hz;
    const double t = (std::log(w) - std::log(a.omega)) / (std::log(b.omega) - std::log(a.omega));
    const double beta = std::exp(std::log(a.beta) + t * (std::log(b.beta) - std::log(a.beta)));
    pm.measured_m_s = w / beta;
    pm.relative_error = pm.measured_m_s / pm.exact_m_s - 1;
    pm.seconds = seconds_since(t0);
    return pm;
}

double predicted_phase_error(const physics::Material &m, double thickness_m, double f_hz, double h_m,
                             double time_step_s)
{
    require_material(m, thickness_m, f_hz);
    const double kappa = m.kappa(thickness_m);
    const double mu = kappa * time_step_s / (h_m * h_m);
    const double w = 2 * pi * f_hz;
    const double s = std::sin(w * time_step_s / 2) / (2 * mu);
    if (!(s > 0 && s <= 1))
        return NAN;  // f beyond what the grid can carry
    const double beta = 2 / h_m * std::asin(std::sqrt(s));
    return (w / beta) / physics::a0_phase_velocity(m, thickness_m, f_hz) - 1;
}

CostModel time_cost_model(const std::shared_ptr<const engine::PlateOperator> &op, std::size_t sites,
                          std::size_t foci, std::size_t exciters)
{
    CostModel c;
    c.threads = std::max(1, omp_get_max_threads());
    const double nodes = double(op->grid().node_count());
    const double x = op->params().size_x_m, y = op->params().size_y_m;
    auto time_one = [&](engine::Precision p, std::size_t sources, std::size_t receivers) {
        engine::SimulationOptions so;
        so.precision = p;
        so.engine.threads = 1;
        engine::Simulation sim(op, so);
        const double work = nodes + 4.0 * double(receivers + sources);
        const auto steps = static_cast<size_t>(std::clamp(1.5e7 / work, 20.0, 20000.0));
        for (std::size_t s = 0; s < sources; s++)
            sim.set_source_signal(sim.add_source((0.1 + 0.8 * double(s) / double(sources)) * x, 0.05 * y),
                                  std::vector<double>(3 * steps + 10, 1e-3));
        for (std::size_t r = 0; r < receivers; r++)
            sim.add_receiver((0.05 + 0.9 * double(r) / double(receivers)) * x, 0.93 * y);
        sim.run(10);  // warm-up
        double best = INFINITY;  // the fastest of three: a shared machine only ever slows it down
        for (int rep = 0; rep < 3; rep++) {
            const auto t0 = Clock::now();
            sim.run(steps);
            best = std::min(best, seconds_since(t0) / double(steps));
        }
        return best;
    };
    for (int p = 0; p < 2; p++) {
        const auto prec = p == 0 ? engine::Precision::f32 : engine::Precision::f64;
        c.seconds_per_step_simulate[p] = time_one(prec, 1, sites);
        c.seconds_per_step_verify[p] = time_one(prec, exciters, foci);
        c.seconds_per_node_step[p] = c.seconds_per_step_simulate[p] / nodes;
    }
    return c;
}

Prediction predict_calibration(const scene::Scene &s, const scene::PlateSetup &setup, CostModel *cost_out)
{
    if (!s.calibration_sections())
        throw std::invalid_argument(s.file + ": not a calibration scene");
    Prediction p;
    p.setting.points_per_wavelength = s.simulation.points_per_wavelength;
    p.setting.precision = s.simulation.precision;
    p.setting.courant = s.simulation.courant;
    p.f_max_hz = scene_f_max(s);
    const engine::PlateOperator &op = *setup.plate;
    const engine::Grid &g = op.grid();
    p.h_m = g.h;
    p.nx = g.nx;
    p.ny = g.ny;
    p.time_step_s = setup.options.time_step_s > 0 ? setup.options.time_step_s
                                                  : setup.options.courant * op.max_time_step();
    p.phase_error = predicted_phase_error(s.plate.material, s.plate.thickness_m, p.f_max_hz, g.h, p.time_step_s);
    const double nodes = double(g.node_count());
    const pipeline::CalibrationSpec &c = *s.calibration;
    p.steps_per_window = std::ceil(c.window_s / p.time_step_s);
    // Emitters: one per focus, plus the probe points calibrate() adds when K < 4.
    const double lambda_c = kirchhoff_wavelength(op.kappa(), s.pulse->centre_hz);
    const size_t K = s.foci->points.size();
    const bool fixed = s.exciters->placement == pipeline::PlacementMode::fixed;
    size_t probes = 0;
    if (!fixed && K < 4) {
        const pipeline::Rect &a = s.active_area->area;
        for (int j = 0; j < 3; j++)
            for (int i = 0; i < 3; i++) {
                const double x = a.x0_m + (a.x1_m - a.x0_m) * (1 + 2 * i) / 6.0;
                const double y = a.y0_m + (a.y1_m - a.y0_m) * (1 + 2 * j) / 6.0;
                bool near = false;
                for (const pipeline::FocusPoint &f : s.foci->points)
                    near |= std::hypot(x - f.at.x_m, y - f.at.y_m) < lambda_c / 2;
                probes += near ? 0 : 1;
            }
    }
    p.emitters = double(K + probes);
    pipeline::Band band;
    band.plate_x_m = s.plate.size_x_m;
    band.plate_y_m = s.plate.size_y_m;
    band.frame_margin_m = s.active_area->frame_margin_m;
    band.active_area = s.active_area->area;
    band.clearance_m = s.active_area->clearance_m;
    p.sites = fixed ? double(s.exciters->positions.size())
                    : double(pipeline::candidate_sites(band, s.exciters->site_spacing_m.value_or(lambda_c / 8)).size());
    // Simulations run one per core: rounds of `threads` at a time.
    const CostModel cost = time_cost_model(setup.plate, size_t(p.sites), K, s.exciters->count);
    if (cost_out)
        *cost_out = cost;
    const int pi_ = p.setting.precision == engine::Precision::f32 ? 0 : 1;
    const double P = cost.threads;
    // Each recording is resampled to the search rate (soxr): timed on one trace.
    const double rate_d = std::max(2000.0, std::ceil(4.0 * pipeline::pulse_max_frequency_hz(*s.pulse)));
    std::vector<double> trace(size_t(p.steps_per_window));
    for (size_t n = 0; n < trace.size(); n++)
        trace[n] = std::sin(0.01 * double(n)) * std::exp(-1e-4 * double(n));
    const auto t0 = Clock::now();
    const int reps = 3;
    for (int r = 0; r < reps; r++)
        (void)pipeline::resample(trace, 1.0 / p.time_step_s, rate_d);
    const double resample_s = seconds_since(t0) / reps;
    const double sim_s = (cost.seconds_per_step_simulate[pi_] * p.steps_per_window + p.sites * resample_s) *
                         std::ceil(p.emitters / P);
    const double drive_steps = (c.truncate_fraction * c.window_s + c.verify_tail_s) / p.time_step_s;
    // Verification: the full-scale pass, the final pass, and the snapshot rerun to the focus instant.
    const double verify_s = cost.seconds_per_step_verify[pi_] *
                            (2 * drive_steps + c.truncate_fraction * c.window_s / p.time_step_s) *
                            std::ceil(double(K) / P);
    p.seconds = sim_s + verify_s;
    // Memory: each running simulation keeps its field (3 levels) and its
    // traces (double per receiver per step); the stored recordings are float
    // at the search rate.
    const double T = p.setting.precision == engine::Precision::f32 ? 4 : 8;
    const double running = std::min(P, p.emitters);
    const double bytes = running * (3 * nodes * T + p.sites * p.steps_per_window * 8) +
                         p.emitters * p.sites * c.window_s * rate_d * 4;
    p.memory_mb = status_mb("VmRSS:") + bytes / (1024.0 * 1024.0);
    return p;
}

Choice choose_points_per_wavelength(const scene::Scene &s, double target)
{
    const double f = scene_f_max(s);
    const double kappa = s.plate.material.kappa(s.plate.thickness_m);
    const double lambda = kirchhoff_wavelength(kappa, f);
    auto choice_at = [&](double N) {
        Choice c;
        c.points_per_wavelength = N;
        c.h_m = engine::make_grid(s.plate.size_x_m, s.plate.size_y_m, lambda / N).h;
        c.effective_ppw = lambda / c.h_m;
        const double k = s.simulation.courant * c.h_m * c.h_m / (4 * kappa);  // interior stability bound
        c.predicted_error = predicted_phase_error(s.plate.material, s.plate.thickness_m, f, c.h_m, k);
        return c;
    };
    constexpr double N_max = 80, step = 0.25;
    const double floor_err = choice_at(N_max).predicted_error;
    if (!(std::abs(floor_err) <= target))
        throw std::invalid_argument(s.file + ": calibration.accuracy: " + fmt("%g", target) +
                                    " is not reachable: the error is still " + fmt("%.3g", std::abs(floor_err)) +
                                    " at 80 points per wavelength (Kirchhoff model vs exact A0 at " + fmt("%.0f", f) +
                                    " Hz)");
    Choice c = choice_at(N_max);
    for (double N = N_max; N >= 4; N -= step) {
        const Choice here = choice_at(N);
        if (!(std::abs(here.predicted_error) <= target))
            break;
        c = here;
    }
    return c;
}

std::optional<Choice> apply_accuracy_target(scene::Scene &s)
{
    if (!s.calibration || !s.calibration->accuracy)
        return std::nullopt;
    Choice c = choose_points_per_wavelength(s, *s.calibration->accuracy);
    s.simulation.f_max_hz = scene_f_max(s);
    s.simulation.points_per_wavelength = c.points_per_wavelength;
    s.simulation.grid_spacing_m.reset();
    return c;
}

std::string dry_run_summary(const std::string &scene_path)
{
    scene::Scene s = scene::load_scene(scene_path);
    if (!s.calibration_sections())
        throw std::runtime_error(scene_path + ": not a calibration scene: it needs [active_area], [exciters], "
                                              "[foci], [pulse] and [calibration] sections");
    const std::optional<Choice> choice = apply_accuracy_target(s);
    const scene::PlateSetup setup = scene::build_plate(s);
    CostModel cost;
    const Prediction p = predict_calibration(s, setup, &cost);
    std::ostringstream o;
    o << "scene " << s.name << " (dry run: nothing simulated)\n";
    if (choice)
        o << "  accuracy target   " << fmt("%g %%", 100 * *s.calibration->accuracy)
          << " phase-velocity error at f_max: cheapest grid " << fmt("%.2f", choice->points_per_wavelength)
          << " points per wavelength\n";
    else
        o << "  accuracy target   none (calibration.accuracy unset): the scene's [simulation] settings\n";
    o << "  setting           " << fmt("%.2f", s.simulation.points_per_wavelength) << " points per wavelength at "
      << fmt("%.0f Hz", p.f_max_hz) << " (grid " << fmt("%.2f", kirchhoff_wavelength(setup.plate->kappa(), p.f_max_hz) / p.h_m)
      << "), " << engine::precision_name(p.setting.precision) << ", Courant " << fmt("%g", p.setting.courant)
      << ", model " << model_name(PlateModel::kirchhoff) << "\n";
    o << "  grid              " << p.nx << " x " << p.ny << " cells of " << fmt("%.2f mm", p.h_m * 1e3) << ", step "
      << fmt("%.3g us", p.time_step_s * 1e6) << ", " << fmt("%.0f", p.steps_per_window) << " steps per "
      << fmt("%g s", s.calibration->window_s) << " window\n";
    o << "  predicted error   " << fmt("%+.3f %%", 100 * p.phase_error) << " phase velocity at f_max vs exact A0\n";
    o << "  predicted time    " << fmt("%.1f s", p.seconds) << " (" << fmt("%.0f", p.emitters) << " simulations x "
      << fmt("%.0f", p.sites) << " sites, " << cost.threads << " threads, "
      << fmt("%.3g ms", cost.seconds_per_step_simulate[p.setting.precision == engine::Precision::f32 ? 0 : 1] * 1e3)
      << " per step measured now)\n";
    o << "  predicted memory  " << fmt("%.0f MB", p.memory_mb) << " peak resident\n";
    return o.str();
}

void reset_peak_rss()
{
    malloc_trim(0);  // hand freed heap back, so the peak counts what this run needs
    std::ofstream f("/proc/self/clear_refs");
    f << "5";  // resets VmHWM (Linux >= 4.0)
}

double current_peak_rss_mb() { return status_mb("VmHWM:"); }

StudyResult run_accuracy_study(const std::string &scene_path, const StudyOptions &o, const StudyProgress &progress)
{
    const scene::Scene base = scene::load_scene(scene_path);
    if (!base.calibration_sections())
        throw std::runtime_error(scene_path + ": not a calibration scene: the study runs the calibration pipeline");
    if (o.points_per_wavelength.empty())
        throw std::invalid_argument("study: no points-per-wavelength values");
    StudyResult r;
    r.scene_file = scene_path;
    r.scene_name = base.name;
    r.f_max_hz = scene_f_max(base);
    r.lambda_f_max_m = kirchhoff_wavelength(base.plate.material.kappa(base.plate.thickness_m), r.f_max_hz);

    DispersionSetting s0;
    s0.points_per_wavelength = base.simulation.points_per_wavelength;
    s0.precision = base.simulation.precision;
    s0.courant = base.simulation.courant;
    const double w0 = base.calibration->window_s;
    auto row = [&](std::string knob, DispersionSetting s, double window) {
        StudyRow x;
        x.knob = std::move(knob);
        x.setting = s;
        x.window_s = window;
        return x;
    };
    for (double N : o.points_per_wavelength) {
        DispersionSetting s = s0;
        s.points_per_wavelength = N;
        r.rows.push_back(row("ppw", s, w0));
    }
    if (o.include_precision) {
        DispersionSetting s = s0;
        s.precision = s0.precision == engine::Precision::f32 ? engine::Precision::f64 : engine::Precision::f32;
        r.rows.push_back(row("precision", s, w0));
    }
    for (double c : o.courants) {
        DispersionSetting s = s0;
        s.courant = c;
        r.rows.push_back(row("courant", s, w0));
    }
    for (double wf : o.window_factors)
        r.rows.push_back(row("window", s0, w0 * wf));
    if (o.include_model) {
        DispersionSetting s = s0;
        s.model = PlateModel::mindlin;
        r.rows.push_back(row("model", s, w0));
    }
    // The reference: the finest grid, double precision; run last, so the
    // memory the big run leaves in the allocator does not count for the others.
    DispersionSetting ref = s0;
    ref.points_per_wavelength = *std::max_element(o.points_per_wavelength.begin(), o.points_per_wavelength.end());
    ref.precision = engine::Precision::f64;
    r.rows.push_back(row("reference", ref, w0));
    const size_t ref_row = r.rows.size() - 1;

    struct FocusOut {
        double px = 0, py = 0, contrast = 0;
    };
    std::vector<std::vector<FocusOut>> per_focus(r.rows.size());
    for (size_t i = 0; i < r.rows.size(); i++) {
        StudyRow &x = r.rows[i];
        const std::string label = x.knob + " N=" + fmt("%g", x.setting.points_per_wavelength) + " " +
                                  engine::precision_name(x.setting.precision) + " C=" + fmt("%g", x.setting.courant) +
                                  " T=" + fmt("%g", x.window_s) + " s " + model_name(x.setting.model);
        if (progress)
            progress("[" + std::to_string(i + 1) + "/" + std::to_string(r.rows.size()) + "] " + label);
        if (!model_available(x.setting.model)) {
            x.note = std::string("model ") + model_name(x.setting.model) +
                     " not run: the thick-plate effect is not composable into calibrate() yet (no loss; hook)";
            continue;
        }
        scene::Scene sc = base;
        sc.simulation.f_max_hz = r.f_max_hz;
        sc.simulation.points_per_wavelength = x.setting.points_per_wavelength;
        sc.simulation.grid_spacing_m.reset();
        sc.simulation.time_step_s.reset();
        sc.simulation.precision = x.setting.precision;
        sc.simulation.courant = x.setting.courant;
        sc.calibration->window_s = x.window_s;
        sc.calibration->accuracy.reset();
        sc.exciters->restarts = std::min(sc.exciters->restarts, o.search_restarts);
        sc.exciters->iterations = std::min(sc.exciters->iterations, o.search_iterations);
        try {
            const scene::PlateSetup setup = scene::build_plate(sc);
            // Measured on the grid the scene gets: make_grid rounds h down so
            // that it divides the plate, which makes it a little finer than N asks.
            DispersionSetting on_grid = x.setting;
            on_grid.points_per_wavelength = r.lambda_f_max_m / setup.plate->grid().h;
            x.phase = measure_phase_velocity(sc.plate.material, sc.plate.thickness_m, r.f_max_hz, on_grid);
            x.predicted = predict_calibration(sc, setup, i == 0 ? &r.cost : nullptr);
            const pipeline::CalibrationInput in = scene::calibration_input(sc, setup, "");
            pipeline::check_feasible(in);
            reset_peak_rss();
            const auto t0 = Clock::now();
            const pipeline::CalibrationResult res = pipeline::calibrate(in);
            x.wall_s = seconds_since(t0);
            x.peak_rss_mb = current_peak_rss_mb();
            const pipeline::Verification &v = res.verification;
            x.simulate_s = res.times.simulation_s;
            x.search_s = res.times.search_s;
            x.verify_s = res.times.verification_s;
            x.contrast_db = INFINITY;
            for (size_t f = 0; f < v.foci.size(); f++) {
                const pipeline::FocusMetrics &fm = v.foci[f];
                const double contrast = v.foci.size() > 1 ? fm.contrast_db
                                                          : 20 * std::log10(fm.peak_m / fm.max_elsewhere_m);
                const Point2 at = snapshot_peak(v.snapshots[f], v.grid_nx, v.grid_ny, v.grid_h_m);
                FocusOut fo{at.x, at.y, contrast};
                per_focus[i].push_back(fo);
                x.focus_position_error_m = std::max(x.focus_position_error_m,
                                                    std::hypot(fo.px - v.foci[f].at.x_m, fo.py - v.foci[f].at.y_m));
                x.contrast_db = std::min(x.contrast_db, fo.contrast);
            }
            x.ran = true;
        } catch (const std::exception &e) {
            x.note = e.what();
        }
        if (progress)
            progress(x.ran ? "    phase error " + fmt("%+.3f %%", 100 * x.phase.relative_error) + ", calibrate " +
                                 fmt("%.1f s", x.wall_s) + " (predicted " + fmt("%.1f s", x.predicted.seconds) +
                                 "), " + fmt("%.0f MB", x.peak_rss_mb) + " (predicted " +
                                 fmt("%.0f MB)", x.predicted.memory_mb)
                           : "    skipped: " + x.note);
    }
    // Against the reference.
    if (r.rows[ref_row].ran)
        for (size_t i = 0; i < r.rows.size(); i++) {
            if (!r.rows[i].ran || per_focus[i].size() != per_focus[ref_row].size())
                continue;
            for (size_t f = 0; f < per_focus[i].size(); f++) {
                const FocusOut &a = per_focus[i][f], &b = per_focus[ref_row][f];
                r.rows[i].focus_shift_m = std::max(r.rows[i].focus_shift_m, std::hypot(a.px - b.px, a.py - b.py));
                r.rows[i].contrast_change_db = std::max(r.rows[i].contrast_change_db, std::abs(a.contrast - b.contrast));
            }
        }
    return r;
}

std::string write_study_report(const StudyResult &r, const std::string &dir)
{
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        throw std::runtime_error(dir + ": cannot create the report directory: " + ec.message());
    std::ostringstream csv;
    csv << "scene,knob,points_per_wavelength,precision,courant,window_s,model,ran,h_m,nx,ny,time_step_s,"
           "phase_error_predicted,phase_error_measured,phase_velocity_exact_m_s,phase_velocity_measured_m_s,"
           "focus_position_error_m,focus_shift_vs_reference_m,contrast_db,contrast_change_db,wall_s,simulate_s,search_s,"
           "verify_s,"
           "wall_s_predicted,peak_rss_mb,peak_rss_mb_predicted,note\n";
    for (const StudyRow &x : r.rows) {
        std::string note = x.note;
        std::replace(note.begin(), note.end(), ',', ';');
        std::replace(note.begin(), note.end(), '"', '\'');
        csv << r.scene_name << ',' << x.knob << ',' << x.setting.points_per_wavelength << ','
            << engine::precision_name(x.setting.precision) << ',' << x.setting.courant << ',' << x.window_s << ','
            << model_name(x.setting.model) << ',' << (x.ran ? 1 : 0) << ',' << x.predicted.h_m << ',' << x.predicted.nx
            << ',' << x.predicted.ny << ',' << x.predicted.time_step_s << ',' << x.predicted.phase_error << ','
            << x.phase.relative_error << ',' << x.phase.exact_m_s << ',' << x.phase.measured_m_s << ','
            << x.focus_position_error_m << ',' << x.focus_shift_m << ',' << x.contrast_db << ','
            << x.contrast_change_db << ',' << x.wall_s << ',' << x.simulate_s << ',' << x.search_s << ','
            << x.verify_s << ',' << x.predicted.seconds << ',' << x.peak_rss_mb << ','
            << x.predicted.memory_mb << ",\"" << note << "\"\n";
    }
    io::write_file_atomic(dir + "/accuracy.csv", csv.str());

    // The points-per-wavelength sweep, cheapest (coarsest) first: the cost
    // grows like N^4, the measured wall time is noisier than that on a shared machine.
    std::vector<const StudyRow *> sweep;
    for (const StudyRow &x : r.rows)
        if (x.ran && x.knob == "ppw")
            sweep.push_back(&x);
    std::sort(sweep.begin(), sweep.end(), [](auto *a, auto *b) {
        return a->setting.points_per_wavelength < b->setting.points_per_wavelength;
    });

    report::Plot p;
    p.title = r.scene_name + ": error vs calibration time (f_max " + fmt("%.0f", r.f_max_hz) + " Hz)";
    p.x = report::Axis("calibrate wall time (s)", report::AxisScale::log);
    p.y = report::Axis("error (%)", report::AxisScale::log);
    std::vector<double> t, e, tp, ep, fs;
    for (const StudyRow *x : sweep) {
        t.push_back(x->wall_s);
        e.push_back(100 * std::abs(x->phase.relative_error));
        tp.push_back(x->predicted.seconds);
        ep.push_back(100 * std::abs(x->predicted.phase_error));
        fs.push_back(100 * x->focus_shift_m / r.lambda_f_max_m);
    }
    if (!sweep.empty()) {
        report::Series a("phase velocity at f_max, measured", t, e);
        a.markers = true;
        p.add(a);
        report::Series b("phase velocity, model (predicted time)", tp, ep, report::LineStyle::dashed);
        b.markers = true;
        p.add(b);
        report::Series c("focus shift vs reference, % of lambda(f_max)", t, fs, report::LineStyle::dotted);
        c.markers = true;
        p.add(c);
        p.legend = report::LegendPosition::bottom_left;
        report::write_plot(p, dir + "/accuracy.svg");
        report::write_plot(p, dir + "/accuracy.png");
    }

    std::ostringstream md;
    md << "### " << r.scene_name << " (f_max " << fmt("%.0f", r.f_max_hz) << " Hz, Kirchhoff lambda(f_max) "
       << fmt("%.1f", r.lambda_f_max_m * 1e3) << " mm)\n\n";
    double kirchhoff_gap = 0;
    {
        const scene::Scene sc = scene::load_scene(r.scene_file);
        const physics::Material &m = sc.plate.material;
        const double d = sc.plate.thickness_m, exact = physics::a0_phase_velocity(m, d, r.f_max_hz);
        kirchhoff_gap = physics::kirchhoff_phase_velocity(m, d, r.f_max_hz) / exact - 1;
        md << "Model gap at f_max (dispersion solver, no grid): Kirchhoff "
           << fmt("%+.3f %%", 100 * kirchhoff_gap)
           << ", Mindlin " << fmt("%+.3f %%", 100 * (physics::mindlin_phase_velocity(m, d, r.f_max_hz) / exact - 1))
           << " against exact A0: the floor no grid refinement of the Kirchhoff scheme removes.\n\n";
    }
    md << "To reach a phase-velocity error at f_max (measured, points-per-wavelength sweep, "
       << (sweep.empty() ? "-" : engine::precision_name(sweep[0]->setting.precision)) << "):\n\n";
    md << "| target | cheapest setting | measured error | you pay (calibrate) | memory | focus shift | contrast change |\n";
    md << "|---|---|---|---|---|---|---|\n";
    for (double target : {0.10, 0.03, 0.01, 0.003, 0.001}) {
        const StudyRow *hit = nullptr;
        for (const StudyRow *x : sweep)
            if (std::abs(x->phase.relative_error) <= target) {
                hit = x;
                break;
            }
        md << "| " << fmt("%g %%", 100 * target) << " | ";
        if (std::abs(kirchhoff_gap) >= target) {
            md << "not robustly: below the Kirchhoff gap " << fmt("%+.3f %%", 100 * kirchhoff_gap);
            if (hit)
                md << " (the grid error cancels it near " << fmt("%g", hit->setting.points_per_wavelength)
                   << " points/wavelength: " << fmt("%+.3f %%", 100 * hit->phase.relative_error) << " in "
                   << fmt("%.1f s", hit->wall_s) << "; finer grids are worse)";
            md << " | | | | | |\n";
            continue;
        }
        if (!hit) {
            md << "not reached in this sweep | | | | | |\n";
            continue;
        }
        md << fmt("%g", hit->setting.points_per_wavelength) << " points/wavelength | "
           << fmt("%+.3f %%", 100 * hit->phase.relative_error) << " | " << fmt("%.1f s", hit->wall_s) << " | "
           << fmt("%.0f MB", hit->peak_rss_mb) << " | " << fmt("%.1f mm", 1e3 * hit->focus_shift_m) << " | "
           << fmt("%.2f dB", hit->contrast_change_db) << " |\n";
    }
    md << "\nEvery setting (reference = finest grid in double; shift and contrast change against it; "
          "predicted = the --dry-run models):\n\n";
    md << "| knob | N | precision | Courant | window s | grid | phase err predicted | phase err measured | "
          "focus pos err mm | shift mm | contrast dB | change dB | wall s | sim+verify s (pred) | memory MB (pred) |\n";
    md << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const StudyRow &x : r.rows) {
        md << "| " << x.knob << " | " << fmt("%g", x.setting.points_per_wavelength) << " | "
           << engine::precision_name(x.setting.precision) << " | " << fmt("%g", x.setting.courant) << " | "
           << fmt("%g", x.window_s) << " | ";
        if (!x.ran) {
            md << "skipped: " << x.note << " | | | | | | | | | |\n";
            continue;
        }
        md << x.predicted.nx << " x " << x.predicted.ny << " (N " << fmt("%.2f", r.lambda_f_max_m / x.predicted.h_m)
           << ") | " << fmt("%+.3f %%", 100 * x.predicted.phase_error)
           << " | " << fmt("%+.3f %%", 100 * x.phase.relative_error) << " | "
           << fmt("%.1f", 1e3 * x.focus_position_error_m) << " | " << fmt("%.1f", 1e3 * x.focus_shift_m) << " | "
           << fmt("%.1f", x.contrast_db) << " | " << fmt("%.2f", x.contrast_change_db) << " | "
           << fmt("%.1f", x.wall_s) << " | " << fmt("%.1f", x.simulate_s + x.verify_s) << " ("
           << fmt("%.1f", x.predicted.seconds) << ") | "
           << fmt("%.0f", x.peak_rss_mb) << " (" << fmt("%.0f", x.predicted.memory_mb) << ") |\n";
    }
    md << "\nCost model at the first swept setting: " << fmt("%.3g", r.cost.seconds_per_node_step[0] * 1e9)
       << " ns (float), " << fmt("%.3g", r.cost.seconds_per_node_step[1] * 1e9)
       << " ns (double) per node-step of a reciprocity simulation (receivers included) on one core, "
       << r.cost.threads << " threads.\n";
    io::write_file_atomic(dir + "/accuracy.md", md.str());
    return md.str();
}

}  // namespace calib::study
