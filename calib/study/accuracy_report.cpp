#include "study/accuracy.h"

#include "io/atomic_file.h"
#include "model/error_model.h"
#include "physics/dispersion.h"
#include "report/plot.h"
#include "io/format.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace calib::study {

namespace {

using io::fmt;

} // namespace

std::string write_study_report(const StudyResult &r, const std::string &dir)
{
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        throw std::runtime_error(dir + ": cannot create the report directory: " + ec.message());
    std::ostringstream csv;
    csv << "scene,knob,points_per_wavelength,precision,courant,window_s,model,ran,h_m,nx,ny,time_step_s,"
           "phase_error_predicted,phase_error_measured,phase_velocity_exact_m_s,phase_velocity_measured_m_s,"
           "focus_position_error_m,focus_shift_vs_reference_m,contrast_db,contrast_change_db,wall_s,simulate_s,search_"
           "s,"
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
            << x.focus_position_error_m << ',' << x.focus_shift_m << ',' << x.contrast_db << ',' << x.contrast_change_db
            << ',' << x.wall_s << ',' << x.simulate_s << ',' << x.search_s << ',' << x.verify_s << ','
            << x.predicted.seconds << ',' << x.peak_rss_mb << ',' << x.predicted.memory_mb << ",\"" << note << "\"\n";
    }
    io::write_file_atomic(dir + "/accuracy.csv", csv.str());

    // The points-per-wavelength sweep, cheapest (coarsest) first: the cost
    // grows like N^4, the measured wall time is noisier than that on a shared machine.
    std::vector<const StudyRow *> sweep;
    for (const StudyRow &x : r.rows)
        if (x.ran && x.knob == "ppw")
            sweep.push_back(&x);
    std::sort(sweep.begin(), sweep.end(),
              [](auto *a, auto *b) { return a->setting.points_per_wavelength < b->setting.points_per_wavelength; });

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
        md << "Model gap at f_max (dispersion solver, no grid): Kirchhoff " << fmt("%+.3f %%", 100 * kirchhoff_gap)
           << ", Mindlin " << fmt("%+.3f %%", 100 * (physics::mindlin_phase_velocity(m, d, r.f_max_hz) / exact - 1))
           << " against exact A0: the floor no grid refinement of the Kirchhoff scheme removes.\n\n";
    }
    md << "To reach a phase-velocity error at f_max (measured, points-per-wavelength sweep, "
       << (sweep.empty() ? "-" : engine::precision_name(sweep[0]->setting.precision)) << "):\n\n";
    md << "| target | cheapest setting | measured error | you pay (calibrate) | memory | focus shift | contrast change "
          "|\n";
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
    md << "\nFocus against the reference, points-per-wavelength sweep (every setting plays the reference's "
          "exciter placement):\n\n| N | focus shift mm | contrast change dB |\n|---|---|---|\n";
    for (const StudyRow *x : sweep)
        md << "| " << fmt("%g", x->setting.points_per_wavelength) << " | " << fmt("%.2f", 1e3 * x->focus_shift_m)
           << " | " << fmt("%.3f", x->contrast_change_db) << " |\n";
    md << "\nEvery setting (reference = finest grid in double, run first; its placement search chooses the "
          "exciters every other setting plays; shift and contrast change against it; predicted = the --dry-run "
          "models; the phase columns are the Kirchhoff strip's, so none for the thick plate):\n\n";
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
           << ") | "
           << (x.setting.model == PlateModel::kirchhoff ? fmt("%+.3f %%", 100 * x.predicted.phase_error) : "-") << " | "
           << (x.setting.model == PlateModel::kirchhoff ? fmt("%+.3f %%", 100 * x.phase.relative_error) : "-") << " | "
           << fmt("%.1f", 1e3 * x.focus_position_error_m) << " | " << fmt("%.1f", 1e3 * x.focus_shift_m) << " | "
           << fmt("%.1f", x.contrast_db) << " | " << fmt("%.2f", x.contrast_change_db) << " | " << fmt("%.1f", x.wall_s)
           << " | " << fmt("%.1f", x.simulate_s + x.verify_s) << " (" << fmt("%.1f", x.predicted.seconds) << ") | "
           << fmt("%.0f", x.peak_rss_mb) << " (" << fmt("%.0f", x.predicted.memory_mb) << ") |\n";
    }
    md << "\nCost model at the first swept setting: " << fmt("%.3g", r.cost.seconds_per_node_step * 1e9) << " ns ("
       << engine::precision_name(r.cost.precision)
       << ") per node-step of a reciprocity simulation (receivers included) on one core, " << r.cost.threads
       << " threads.\n";
    io::write_file_atomic(dir + "/accuracy.md", md.str());
    return md.str();
}

} // namespace calib::study
