// The robustness study's files: robustness.csv (one row per plate), the
// tornado plot (cairo through report/canvas.h) and robustness.md.
#include "study/robustness.h"

#include "io/atomic_file.h"
#include "io/format.h"
#include "report/canvas.h"
#include "report/plot.h"
#include "report/ticks.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>

namespace calib::study {

namespace {

using io::fmt;
using pipeline::CaseFigures;
using pipeline::ToleranceCase;

double exciter_shift_mm(const pipeline::Perturbation &p)
{
    double m = 0;
    for (pipeline::Point o : p.exciter_offsets_m)
        m = std::max(m, std::hypot(o.x_m, o.y_m));
    return m * 1e3;
}

void csv_figures(std::ostringstream &o, const CaseFigures &c)
{
    o << ',' << c.worst_whole_area_contrast_db << ',' << c.worst_focus_id << ',' << c.min_peak_m * 1e6 << ','
      << c.max_peak_m * 1e6 << ',' << c.max_offset_m * 1e3 << ',' << c.max_lead_time_s * 1e3 << ',' << c.foci_passing
      << ',' << c.foci_failing << ',' << c.area_crossings << ',' << c.peak_per_energy;
}

const char *figure_columns = "worst_whole_area_contrast_db,worst_focus,min_peak_um,max_peak_um,max_offset_mm,"
                             "max_lead_ms,foci_passing,foci_failing,area_crossings,peak_per_energy_m_per_n_sqrt_s";

// One tornado row per tolerance: the change of the worst-focus whole-area
// contrast at each end of its range, against the nominal plate.
struct Row {
    std::string factor;
    std::vector<std::pair<std::string, double>> ends; // case name, change (dB)
    std::vector<unsigned> fails;
    double low = 0, high = 0;
};

std::vector<Row> tornado_rows(const RobustnessResult &r)
{
    std::vector<Row> rows;
    std::map<std::string, std::size_t> at;
    for (const ToleranceCase &c : r.report.cases) {
        if (c.perturbation.factor == "combined")
            continue;
        auto [it, fresh] = at.try_emplace(c.perturbation.factor, rows.size());
        if (fresh)
            rows.push_back({c.perturbation.factor, {}, {}, 0, 0});
        Row &row = rows[it->second];
        const double d = c.table.worst_whole_area_contrast_db - r.report.nominal.worst_whole_area_contrast_db;
        row.ends.push_back({c.perturbation.name, d});
        row.fails.push_back(c.table.foci_failing);
        row.low = std::min(row.low, d);
        row.high = std::max(row.high, d);
    }
    std::stable_sort(rows.begin(), rows.end(), [](const Row &a, const Row &b) { return a.low < b.low; });
    return rows;
}

void draw_tornado(cairo_t *cr, const std::vector<Row> &rows, const RobustnessResult &r, int w)
{
    namespace cv = report::canvas;
    const double left = 190, right = w - 30, top = 70, row_h = 44;
    double lo = -1, hi = 1;
    for (const Row &x : rows) {
        lo = std::min(lo, x.low);
        hi = std::max(hi, x.high);
    }
    const double pad = 0.35 * (hi - lo); // room for the labels at the bar ends
    lo -= pad;
    hi += pad;
    report::Axis axis("change of the worst-focus whole-area contrast (dB)");
    const report::Ticks t = report::make_ticks(axis, lo, hi, "x");
    auto X = [&](double v) { return left + (v - t.lo) / (t.hi - t.lo) * (right - left); };
    cv::set_color(cr, {0, 0, 0});
    cv::text(cr, w / 2.0, 22, "Which tolerance costs most: " + r.scene_name, 16, cv::Anchor::middle);
    cv::text(cr, w / 2.0, 44,
             "nominal worst-focus whole-area contrast " +
                 fmt("%.2f dB", r.report.nominal.worst_whole_area_contrast_db) + ", verdict fails at " +
                 std::to_string(r.report.nominal.foci_failing),
             12, cv::Anchor::middle);
    const double bottom = top + row_h * double(rows.size());
    cairo_set_line_width(cr, 1);
    for (std::size_t i = 0; i < t.major.size(); i++) {
        cv::set_color(cr, {200, 200, 200});
        cairo_move_to(cr, X(t.major[i]), top - 6);
        cairo_line_to(cr, X(t.major[i]), bottom);
        cairo_stroke(cr);
        cv::set_color(cr, {0, 0, 0});
        cv::text(cr, X(t.major[i]), bottom + 14, t.labels[i], 11, cv::Anchor::middle);
    }
    cv::text(cr, (left + right) / 2, bottom + 36, axis.label, 12, cv::Anchor::middle);
    for (std::size_t i = 0; i < rows.size(); i++) {
        const Row &x = rows[i];
        const double y0 = top + row_h * double(i);
        cv::set_color(cr, {0, 0, 0});
        cv::text(cr, left - 8, y0 + row_h / 2, x.factor, 13, cv::Anchor::end);
        const double bar = (row_h - 10) / double(std::max<std::size_t>(1, x.ends.size()));
        for (std::size_t e = 0; e < x.ends.size(); e++) {
            const double d = x.ends[e].second, y = y0 + 5 + bar * double(e);
            cv::set_color(cr, report::palette(e));
            cairo_rectangle(cr, std::min(X(0), X(d)), y, std::max(1.0, std::abs(X(d) - X(0))), bar - 2);
            cairo_fill(cr);
            cv::set_color(cr, {40, 40, 40});
            const bool to_right = d >= 0;
            cv::text(cr, X(d) + (to_right ? 4 : -4), y + bar / 2 - 1,
                     x.ends[e].first + fmt(" %+.2f dB", d) +
                         (x.fails[e] ? ", " + std::to_string(x.fails[e]) + " fail" : ""),
                     10, to_right ? cv::Anchor::start : cv::Anchor::end);
        }
    }
    cv::set_color(cr, {0, 0, 0});
    cairo_set_line_width(cr, 1.5);
    cairo_move_to(cr, X(0), top - 6);
    cairo_line_to(cr, X(0), bottom);
    cairo_stroke(cr);
}

std::string figures_md(const std::string &name, const CaseFigures &c, std::size_t foci)
{
    return "| " + name + " | " + fmt("%.2f", c.worst_whole_area_contrast_db) + " (focus " +
           std::to_string(c.worst_focus_id) + ") | " + fmt("%.2f", c.min_peak_m * 1e6) + " - " +
           fmt("%.2f", c.max_peak_m * 1e6) + " | " + fmt("%.1f", c.max_offset_m * 1e3) + " | " +
           fmt("%.1f", c.max_lead_time_s * 1e3) + " | " + std::to_string(c.foci_passing) + " / " +
           std::to_string(foci) + " | " + std::to_string(c.area_crossings) + " |\n";
}

} // namespace

std::string write_robustness_report(const RobustnessResult &r, const std::string &dir)
{
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        throw std::runtime_error(dir + ": cannot create the report directory: " + ec.message());
    const pipeline::ToleranceReport &rep = r.report;
    std::ostringstream csv;
    const bool compensation = r.box.spec.speed_compensation;
    csv << "case,factor,E_scale,rho_scale,thickness_scale,loss_factor,temperature_k,exciter_shift_mm,"
        << figure_columns;
    auto more_columns = [&](const char *prefix) {
        std::istringstream cols(figure_columns);
        for (std::string col; std::getline(cols, col, ',');)
            csv << ',' << prefix << col;
    };
    if (r.robust) // the plain design's figures beside the robust table's
        more_columns("plain_");
    if (compensation) { // as the device plays each plate: stretched by its speed ratio (empty where it is 1)
        csv << ",speed_ratio";
        more_columns("compensated_");
        if (r.robust)
            more_columns("plain_compensated_");
    }
    csv << ",transfer_matrix,seconds\n";
    auto figures_or_empty = [&](const std::optional<CaseFigures> &c) {
        if (c)
            csv_figures(csv, *c);
        else
            csv << ",,,,,,,,,,";
    };
    auto row = [&](const std::string &name, const std::string &factor, const pipeline::Perturbation &p,
                   const CaseFigures &c, const ToleranceCase *tc, double s, const char *H) {
        csv << '"' << name << "\"," << factor << ',' << p.youngs_scale << ',' << p.density_scale << ','
            << p.thickness_scale << ',' << r.box.nominal_loss * p.loss_scale << ',' << p.temperature_k << ','
            << exciter_shift_mm(p);
        csv_figures(csv, c);
        if (r.robust)
            figures_or_empty(tc ? tc->nominal_design : rep.nominal_design);
        if (compensation) {
            csv << ',' << (tc ? tc->speed_ratio : 1.0);
            figures_or_empty(tc ? tc->compensated : std::nullopt);
            if (r.robust)
                figures_or_empty(tc ? tc->nominal_design_compensated : std::nullopt);
        }
        csv << ',' << H << ',' << s << '\n';
    };
    pipeline::Perturbation none;
    row("nominal", "nominal", none, rep.nominal, nullptr, 0, "simulated");
    for (const ToleranceCase &c : rep.cases)
        row(c.perturbation.name, c.perturbation.factor, c.perturbation, c.table, &c, c.seconds,
            c.rescaled ? "rescaled" : "simulated");
    io::write_file_atomic(dir + "/robustness.csv", csv.str());

    const std::vector<Row> rows = tornado_rows(r);
    const int w = 900, h = 150 + 44 * int(rows.size());
    auto draw = [&](cairo_t *cr) { draw_tornado(cr, rows, r, w); };
    io::write_file_atomic(dir + "/robustness_tornado.svg",
                          report::canvas::paint_svg(w, h, draw, "Robustness: " + r.scene_name));
    const std::vector<std::uint8_t> png = report::encode_png(report::canvas::paint_image(w, h, draw));
    io::write_file_atomic(dir + "/robustness_tornado.png",
                          std::string_view(reinterpret_cast<const char *>(png.data()), png.size()));

    std::ostringstream md;
    const pipeline::ToleranceSpec &b = r.box.spec;
    md << "# Robustness: " << r.scene_name << "\n\n";
    md << "Scene `" << r.scene_path << "`; the table calibrated on the nominal plate"
       << (r.robust ? " with the robust design (the plain design's figures beside it)" : "")
       << ", verified on every plate below from that plate's own transfer matrix.\n\n";
    md << "Box" << (r.default_box ? " (the default; the scene has no [tolerance])" : " ([tolerance])") << ": E "
       << fmt("+-%g %%", 100 * b.youngs_rel) << ", rho " << fmt("+-%g %%", 100 * b.density_rel) << ", thickness "
       << fmt("+-%g %%", 100 * b.thickness_rel) << ", loss factor at the pulse centre "
       << (r.box.loss_range ? fmt("%.3f", *b.loss_min) + " - " + fmt("%.3f", *b.loss_max) : std::string("(no range)"))
       << " (nominal " << fmt("%.4f", r.box.nominal_loss) << ")";
    for (double s : b.loss_scale)
        md << ", loss x" << fmt("%g", s);
    md << ", exciters " << fmt("%g mm", b.exciter_position_m * 1e3) << ", temperature "
       << fmt("+-%g K", b.temperature_k) << " at dE/E/dT = " << fmt("%g", r.box.youngs_per_kelvin) << " /K, "
       << b.random_cases << " random combinations (seed " << b.seed << ").\n\n";
    md << "| plate | worst-focus whole-area contrast (dB) | peak (um) | perceived offset (mm) | lead (ms) | "
          "foci passing the verdict | foci whose area beyond lambda/2 crosses |\n|---|---|---|---|---|---|---|\n";
    md << figures_md("nominal", rep.nominal, r.foci);
    if (rep.nominal_design)
        md << figures_md("nominal, plain design", *rep.nominal_design, r.foci);
    for (const ToleranceCase &c : rep.cases) {
        md << figures_md(c.perturbation.name, c.table, r.foci);
        if (c.nominal_design)
            md << figures_md(c.perturbation.name + ", plain design", *c.nominal_design, r.foci);
        const std::string at = fmt(", compensated x%.4f", c.speed_ratio);
        if (c.compensated)
            md << figures_md(c.perturbation.name + at, *c.compensated, r.foci);
        if (c.nominal_design_compensated)
            md << figures_md(c.perturbation.name + ", plain design" + at, *c.nominal_design_compensated, r.foci);
    }
    md << figures_md("**worst over the box**", rep.worst, r.foci);
    if (rep.nominal_design_worst)
        md << figures_md("**worst over the box, plain design**", *rep.nominal_design_worst, r.foci);
    if (rep.compensated_worst)
        md << figures_md("**worst over the box, speed compensated**", *rep.compensated_worst, r.foci);
    if (rep.nominal_design_compensated_worst)
        md << figures_md("**worst over the box, plain design, speed compensated**",
                         *rep.nominal_design_compensated_worst, r.foci);
    md << "\nWhat costs most (worst-focus whole-area contrast against the nominal plate, "
          "`robustness_tornado.svg`):\n\n";
    for (const Row &x : rows) {
        md << "- " << x.factor << ":";
        for (std::size_t e = 0; e < x.ends.size(); e++)
            md << (e ? "," : "") << " " << x.ends[e].first << fmt(" %+.2f dB", x.ends[e].second) << " (" << x.fails[e]
               << " failing the verdict)";
        md << "\n";
    }
    std::size_t rescaled = 0;
    for (const ToleranceCase &c : rep.cases)
        rescaled += c.rescaled;
    md << "\nTransfer matrices: " << rep.cases.size() - rescaled << " plates simulated (one simulation per exciter), "
       << rescaled
       << " rescaled from the nominal H (E, rho, thickness, temperature: exact for the scheme, "
          "docs/robustness.md).\n";
    md << "\nCost: the calibration " << fmt("%.1f s", r.calibration_s) << "; the one-at-a-time cases "
       << fmt("%.1f s", r.one_at_a_time_s) << " (" << fmt("%.2fx", r.one_at_a_time_s / r.calibration_s)
       << " the calibration), the random combinations " << fmt("%.1f s", r.random_s);
    if (r.robust)
        md << "; the robust ensemble (" << rep.ensemble.size() << " member plates) "
           << fmt("%.1f s", rep.ensemble_seconds);
    md << ".\n";
    if (r.robust && rep.nominal_design)
        md << "\nPeak per drive energy (mean over foci, m / (N s^0.5)) on the nominal plate: robust "
           << fmt("%.4g", rep.nominal.peak_per_energy) << ", plain " << fmt("%.4g", rep.nominal_design->peak_per_energy)
           << " (" << fmt("%+.1f %%", 100 * (rep.nominal.peak_per_energy / rep.nominal_design->peak_per_energy - 1))
           << ").\n";
    const std::string text = md.str();
    io::write_file_atomic(dir + "/robustness.md", text);
    return text;
}

} // namespace calib::study
