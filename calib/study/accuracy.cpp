#include "study/accuracy.h"

#include "engine/plate_engine.h"
#include "io/format.h"
#include "model/cost_model.h"
#include "model/error_model.h"
#include "model/resources.h"
#include "physics/dispersion.h"
#include "pipeline/calibrate.h"
#include "pipeline/plan.h"
#include "scene/calibration_input.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>

namespace calib::study {

namespace {

using Clock = std::chrono::steady_clock;
constexpr double pi = std::numbers::pi;

double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

using io::fmt;

struct Ring {
    double beta = 0;  // wavenumber of the mode (rad/m)
    double omega = 0; // fitted angular frequency (rad/s)
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
    eo.skip_stability_check = true; // guaranteed by the bound above
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
    for (size_t n = 0; n < steps; n++) { // a lossless mode: no denormals to flush
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

} // namespace

const char *model_name(PlateModel m) { return m == PlateModel::kirchhoff ? "kirchhoff" : "mindlin"; }

PhaseMeasurement measure_phase_velocity(const physics::Material &m, double thickness_m, double f_hz,
                                        const DispersionSetting &s)
{
    if (!(thickness_m > 0) || !(f_hz > 0) || !(m.kappa(thickness_m) > 0))
        throw std::invalid_argument("accuracy: needs a positive thickness, frequency and bending stiffness");
    if (s.model != PlateModel::kirchhoff)
        throw std::invalid_argument(std::string("accuracy: the strip measurement runs the Kirchhoff engine, not ") +
                                    model_name(s.model));
    if (!(s.points_per_wavelength >= 4) || !(s.courant > 0 && s.courant < 1))
        throw std::invalid_argument("accuracy: points per wavelength must be >= 4 and the Courant factor in (0, 1)");
    const auto t0 = Clock::now();
    PhaseMeasurement pm;
    pm.f_hz = f_hz;
    pm.h_m = physics::kirchhoff_wavelength_m(m.kappa(thickness_m), f_hz) / s.points_per_wavelength;
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
    r.f_max_hz = model::scene_f_max_hz(base);
    r.lambda_f_max_m = physics::kirchhoff_wavelength_m(base.plate.material.kappa(base.plate.thickness_m), r.f_max_hz);

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
    // The reference: the finest grid, double precision. It runs first: its
    // placement search chooses the exciters every other setting then plays
    // (placement = "fixed"), so the focus columns compare grids, not searches.
    DispersionSetting ref = s0;
    ref.points_per_wavelength = *std::max_element(o.points_per_wavelength.begin(), o.points_per_wavelength.end());
    ref.precision = engine::Precision::f64;
    r.rows.insert(r.rows.begin(), row("reference", ref, w0));
    const size_t ref_row = 0;

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
        scene::Scene sc = base;
        sc.simulation.f_max_hz = r.f_max_hz;
        sc.simulation.points_per_wavelength = x.setting.points_per_wavelength;
        sc.simulation.grid_spacing_m.reset();
        sc.simulation.time_step_s.reset();
        sc.simulation.precision = x.setting.precision;
        sc.simulation.courant = x.setting.courant;
        sc.calibration->window_s = x.window_s;
        sc.calibration->accuracy.reset();
        sc.effects.thick_plate = x.setting.model == PlateModel::mindlin;
        if (i == ref_row) {
            sc.exciters->restarts = std::min(sc.exciters->restarts, o.search_restarts);
            sc.exciters->iterations = std::min(sc.exciters->iterations, o.search_iterations);
        } else {
            sc.exciters->placement = pipeline::PlacementMode::fixed;
            sc.exciters->positions = r.exciters;
        }
        try {
            if (i != ref_row && r.exciters.empty())
                throw std::runtime_error("no reference placement (the reference did not run)");
            const scene::PlateSetup setup = scene::build_plate(sc);
            const engine::Grid &g = setup.plate->grid();
            // Measured on the grid the scene gets: make_grid rounds h down so
            // that it divides the plate, which makes it a little finer than N asks.
            DispersionSetting on_grid = x.setting;
            on_grid.points_per_wavelength = r.lambda_f_max_m / g.h;
            if (x.setting.model == PlateModel::kirchhoff)
                x.phase = measure_phase_velocity(sc.plate.material, sc.plate.thickness_m, r.f_max_hz, on_grid);
            const pipeline::CalibrationInput in = scene::calibration_input(sc, setup, "");
            pipeline::check_feasible(in);
            const pipeline::CalibrationPlan plan = pipeline::plan(in);
            const model::CostModel cost = model::measure_cost(in, plan);
            if (i == 1 || r.rows.size() == 1)
                r.cost = cost;
            x.predicted.h_m = g.h;
            x.predicted.nx = g.nx;
            x.predicted.ny = g.ny;
            x.predicted.time_step_s = plan.time_step_s;
            x.predicted.phase_error = model::predicted_phase_error(sc.plate.material, sc.plate.thickness_m, r.f_max_hz,
                                                                   g.h, plan.time_step_s);
            const model::Prediction pred = model::predict(in, plan, &cost);
            x.predicted.seconds = pred.seconds;
            x.predicted.memory_mb = pred.memory_mb;
            model::reset_peak_rss();
            const auto t0 = Clock::now();
            const pipeline::CalibrationResult res = pipeline::calibrate(in);
            x.wall_s = seconds_since(t0);
            x.peak_rss_mb = model::peak_rss_mb();
            if (i == ref_row)
                r.exciters = res.exciters;
            const pipeline::Verification &v = res.verification;
            x.simulate_s = res.times.simulation_s;
            x.search_s = res.times.search_s;
            x.verify_s = res.times.verification_s;
            x.contrast_db = INFINITY;
            for (size_t f = 0; f < v.foci.size(); f++) {
                const pipeline::FocusMetrics &fm = v.foci[f];
                const double contrast =
                    v.foci.size() > 1 ? fm.other_foci_contrast_db : 20 * std::log10(fm.peak_m / fm.max_elsewhere_m);
                const Point2 at = snapshot_peak(v.snapshots[f], v.grid_nx, v.grid_ny, v.grid_h_m);
                FocusOut fo{at.x, at.y, contrast};
                per_focus[i].push_back(fo);
                x.focus_position_error_m =
                    std::max(x.focus_position_error_m, std::hypot(fo.px - v.foci[f].at.x_m, fo.py - v.foci[f].at.y_m));
                x.contrast_db = std::min(x.contrast_db, fo.contrast);
            }
            x.ran = true;
        } catch (const std::exception &e) {
            x.note = e.what();
        }
        if (progress)
            progress(x.ran ? "    phase error " + fmt("%+.3f %%", 100 * x.phase.relative_error) + ", calibrate " +
                                 fmt("%.1f s", x.wall_s) + " (predicted " + fmt("%.1f s", x.predicted.seconds) + "), " +
                                 fmt("%.0f MB", x.peak_rss_mb) + " (predicted " + fmt("%.0f MB)", x.predicted.memory_mb)
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
                r.rows[i].contrast_change_db =
                    std::max(r.rows[i].contrast_change_db, std::abs(a.contrast - b.contrast));
            }
        }
    return r;
}

} // namespace calib::study
