#include "report/calibration_report.h"

#include "io/atomic_file.h"
#include "physics/dispersion.h"
#include "pipeline/verification/verification.h"
#include "report/canvas.h"
#include "report/drive_report.h"
#include "report/field_image.h"
#include "report/modes_section.h"
#include "report/report_fields.h"
#include "report/plot.h"
#include "report/tolerance_report.h"

#include <toml++/toml.h>

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <sstream>

namespace calib::report {

using pipeline::FocusMetrics;
using pipeline::Point;

namespace {

void make_dir(const std::string &dir)
{
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        throw std::runtime_error(dir + ": cannot create the report directory: " + ec.message());
}

toml::array points_array(const std::vector<Point> &pts)
{
    toml::array a;
    for (Point p : pts)
        a.push_back(toml::table{{"x_m", p.x_m}, {"y_m", p.y_m}});
    return a;
}

// metrics.json's safe_range_db: the figures of pipeline::safe_range_text, in
// dB relative to the stored level; [lo, hi], hi "unbounded" for +infinity
// (JSON has no infinity), or "none" when no gain passes.
void insert_safe_range(toml::table &t, const haptic_gain_range &r)
{
    if (!pipeline::any_gain_passes(r)) {
        t.insert("safe_range_db", "none");
        return;
    }
    toml::array a{pipeline::gain_db(r.lo)};
    if (std::isinf(r.hi))
        a.push_back("unbounded");
    else
        a.push_back(pipeline::gain_db(r.hi));
    t.insert("safe_range_db", std::move(a));
}

} // namespace

void write_metrics_json(const std::string &dir, const ReportContext &c)
{
    make_dir(dir);
    const pipeline::CalibrationInput &in = *c.input;
    toml::array foci;
    bool all_cross = true, all_below = true;
    double min_contrast = INFINITY, min_whole = INFINITY;
    bool all_whole_below = true;
    for (const FocusMetrics &m : c.verification->foci) {
        toml::table t{{"id", static_cast<int64_t>(m.id)},
                      {"x_m", m.at.x_m},
                      {"y_m", m.at.y_m},
                      {"peak_m", m.peak_m},
                      {"peak_time_s", m.lead_time_s}, // the lead time by its first name, kept for readers
                      {"lead_time_s", m.lead_time_s},
                      {"lambda_half_m", m.lambda_half_m},
                      {"crosses_threshold", m.crosses_threshold}};
        if (c.mode == "table") {
            t.insert("max_other_foci_m", m.max_other_foci_m);
            t.insert("other_foci_contrast_db", m.other_foci_contrast_db);
            t.insert("spot_diameter_m", m.spot_diameter_m);
            t.insert("max_elsewhere_m", m.max_elsewhere_m);
            t.insert("field_contrast_db", m.field_contrast_db);
            t.insert("others_below_threshold", m.others_below_threshold);
            t.insert("passes", m.passes());
            t.insert("verdict_scope", m.verdict_scope());
            insert_safe_range(t, m.gain_range(in.calibration.threshold_m));
            if (!m.passes())
                t.insert("failure", m.failure(in.calibration.threshold_m));
            if (m.whole_area) {
                t.insert("whole_area_contrast_db", m.whole_area_contrast_db);
                t.insert("max_whole_area_m", m.max_whole_area_m);
                t.insert("whole_area_max_xy_m", toml::array{m.whole_area_max_at.x_m, m.whole_area_max_at.y_m});
                t.insert("whole_area_below_threshold", m.whole_area_below_threshold);
                t.insert("perceived_offset_m", toml::array{m.perceived_offset_m.x_m, m.perceived_offset_m.y_m});
                t.insert("perceived_offset_distance_m", m.perceived_offset_distance_m);
                t.insert("area_above_threshold_m2", m.area_above_threshold_m2);
                if (m.sound)
                    t.insert("sound_exposure_dba", m.sound_exposure_dba);
                min_whole = std::min(min_whole, m.whole_area_contrast_db);
                all_whole_below &= m.whole_area_below_threshold;
            }
            all_below &= m.others_below_threshold;
            min_contrast = std::min(min_contrast, m.other_foci_contrast_db);
        }
        all_cross &= m.crosses_threshold;
        foci.push_back(std::move(t));
    }
    toml::table root{{"scene", in.scene_name},
                     {"scene_file", c.scene_path},
                     {"scene_hash", in.scene_hash},
                     {"table", c.table_path},
                     {"mode", c.mode},
                     {"threshold_m", in.calibration.threshold_m},
                     {"force_full_scale_n", in.exciters.force_full_scale_n},
                     {"pulse_centre_hz", in.pulse.centre_hz},
                     {"exciters", points_array(c.exciters)},
                     {"foci", std::move(foci)},
                     {"all_cross_threshold", all_cross}};
    if (c.mode == "table") {
        // The verdict (data/verdict.h FocusMetrics::passes): what the exit status says.
        const pipeline::VerdictSummary vs = pipeline::summarize_verdict(c.verification->foci);
        if (vs.total > 0)
            root.insert("verdict",
                        toml::table{{"scope", c.verification->foci[vs.worst].verdict_scope()},
                                    {"foci_passing", static_cast<int64_t>(vs.passing)},
                                    {"foci", static_cast<int64_t>(vs.total)},
                                    {"all_pass", vs.all_pass()},
                                    {"worst_focus_id", static_cast<int64_t>(c.verification->foci[vs.worst].id)}});
        root.insert("all_others_below_threshold", all_below);
        root.insert("min_other_foci_contrast_db", min_contrast);
        if (std::isfinite(min_whole)) {
            root.insert("min_whole_area_contrast_db", min_whole);
            root.insert("all_whole_area_below_threshold", all_whole_below);
        }
    }
    add_drive_metrics(root, *root["foci"].as_array(), c);
    if (c.result) {
        const pipeline::PlacementReport &p = c.result->placement;
        root.insert("placement", toml::table{{"chosen_predicted_contrast_db", p.chosen_contrast_db},
                                             {"regular_predicted_contrast_db", p.regular_contrast_db},
                                             {"chosen_distance_variety", p.chosen_variety},
                                             {"regular_distance_variety", p.regular_variety},
                                             {"candidate_sites", static_cast<int64_t>(p.sites.size())},
                                             {"evaluations", static_cast<int64_t>(p.evaluations)},
                                             {"simulations", static_cast<int64_t>(p.simulations)},
                                             {"subset_foci", static_cast<int64_t>(p.focus_subset.size())},
                                             {"subset_cover_m", p.subset_cover_m}});
        if (!p.judged.empty()) { // the search by the verdict (pipeline/placement_verdict.h)
            toml::array judged;
            for (const pipeline::PlacementReport::Judged &j : p.judged) {
                toml::array sites;
                for (std::size_t i : j.chosen)
                    sites.push_back(static_cast<int64_t>(i));
                judged.push_back(toml::table{{"sites", std::move(sites)},
                                             {"foci_passing", static_cast<int64_t>(j.passing)},
                                             {"foci_passing_at_target", static_cast<int64_t>(j.passing_at_target)},
                                             {"worst_whole_area_contrast_db", j.worst_whole_area_db},
                                             {"proxy_contrast_db", j.proxy_db},
                                             {"ghost_probes_seen", static_cast<int64_t>(j.probes)},
                                             {"regular", j.regular},
                                             {"chosen", j.chosen == p.chosen}});
            }
            toml::table &pt = *root["placement"].as_table();
            pt.insert("judged", std::move(judged));
            pt.insert("ghost_probes", points_array(p.ghost_probes));
            pt.insert("proxy_agreements", static_cast<int64_t>(p.proxy_agreements));
            pt.insert("proxy_pairs", static_cast<int64_t>(p.proxy_pairs));
            pt.insert("verdict_s", p.verdict_s);
        }
        const pipeline::StageTimes &s = c.result->times;
        root.insert("times_s", toml::table{{"simulation", s.simulation_s},
                                           {"site_responses", s.site_responses_s},
                                           {"search", s.search_s},
                                           {"transfer", s.transfer_s},
                                           {"signals", s.signals_s},
                                           {"verification", s.verification_s},
                                           {"verdict", s.verdict_s},
                                           {"sound", s.sound_s},
                                           {"total", c.total_s}});
    }
    if (c.modes)
        root.insert("modes", modes_json(*c.modes));
    if (c.result && c.result->tolerance) // the worst case over the scene's [tolerance]
        root.insert("tolerance", tolerance_json(*c.result->tolerance));
    root.insert("peak_rss_mb", c.peak_rss_mb);
    std::ostringstream os;
    os << toml::json_formatter{root} << "\n";
    io::write_file_atomic(dir + "/metrics.json", os.str());
}

namespace {

// Plate coordinates -> SVG pixels (y up on the plate, down in SVG).
struct View {
    double scale, lx, ly, pad = 20;
    double X(double x) const { return pad + x * scale; }
    double Y(double y) const { return pad + (ly - y) * scale; }
};

std::string layout_svg(const ReportContext &c)
{
    const auto &pp = c.input->plate->params();
    View v{420.0 / std::max(pp.size_x_m, pp.size_y_m), pp.size_x_m, pp.size_y_m};
    const double w = v.X(pp.size_x_m) + v.pad, h = v.Y(0) + v.pad;
    std::ostringstream s;
    s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h << "' viewBox='0 0 " << w << " "
      << h << "' font-family='sans-serif' font-size='11'>";
    s << "<rect x='" << v.X(0) << "' y='" << v.Y(pp.size_y_m) << "' width='" << pp.size_x_m * v.scale << "' height='"
      << pp.size_y_m * v.scale << "' fill='#eef3f8' stroke='#333' stroke-width='2'/>";
    const pipeline::Rect &a = c.input->active.area;
    s << "<rect x='" << v.X(a.x0_m) << "' y='" << v.Y(a.y1_m) << "' width='" << (a.x1_m - a.x0_m) * v.scale
      << "' height='" << (a.y1_m - a.y0_m) * v.scale << "' fill='none' stroke='#2a7' stroke-dasharray='6 4'/>";
    if (c.result) {
        for (Point p : c.result->placement.sites)
            s << "<circle cx='" << v.X(p.x_m) << "' cy='" << v.Y(p.y_m) << "' r='1.2' fill='#99a'/>";
        for (size_t i : c.result->placement.regular) {
            const Point p = c.result->placement.sites[i];
            s << "<rect x='" << v.X(p.x_m) - 5 << "' y='" << v.Y(p.y_m) - 5
              << "' width='10' height='10' fill='none' stroke='#36c' stroke-width='1.5'/>";
        }
    }
    const double spot = c.input->foci.points.empty() ? 0 : c.verification->foci[0].lambda_half_m / 2;
    const bool dense = !few_foci(c); // a dense grid: dots, the placement subset ringed, no labels
    for (const pipeline::FocusPoint &f : c.input->foci.points) {
        if (!dense) {
            s << "<circle cx='" << v.X(f.at.x_m) << "' cy='" << v.Y(f.at.y_m) << "' r='" << spot * v.scale
              << "' fill='none' stroke='#e55' stroke-dasharray='3 3'/>";
            s << "<text x='" << v.X(f.at.x_m) + 5 << "' y='" << v.Y(f.at.y_m) - 5 << "' fill='#a22'>" << f.id
              << "</text>";
        }
        s << "<circle cx='" << v.X(f.at.x_m) << "' cy='" << v.Y(f.at.y_m) << "' r='" << (dense ? 2 : 3)
          << "' fill='#e55'/>";
    }
    if (dense && c.result)
        for (size_t i : c.result->placement.focus_subset) {
            const Point p = c.input->foci.points[i].at;
            s << "<circle cx='" << v.X(p.x_m) << "' cy='" << v.Y(p.y_m) << "' r='6' fill='none' stroke='#a22' "
              << "stroke-width='1.5'/>";
        }
    for (size_t e = 0; e < c.exciters.size(); e++) {
        const Point p = c.exciters[e];
        s << "<rect x='" << v.X(p.x_m) - 5 << "' y='" << v.Y(p.y_m) - 5
          << "' width='10' height='10' fill='#d33' stroke='#000'/><text x='" << v.X(p.x_m) + 7 << "' y='"
          << v.Y(p.y_m) + 4 << "' fill='#000'>" << e << "</text>";
    }
    s << "</svg>";
    return s.str();
}

// Min/max per bin: a long trace drawn with <= 2 * bins points, peaks kept.
Series envelope_series(const std::string &label, const std::vector<double> &y, double rate, size_t bins, double scale)
{
    Series s;
    s.label = label;
    const size_t per = std::max<size_t>(1, y.size() / bins);
    for (size_t b = 0; b * per < y.size(); b++) {
        const size_t end = std::min(y.size(), (b + 1) * per);
        auto [lo, hi] = std::minmax_element(y.begin() + static_cast<long>(b * per), y.begin() + static_cast<long>(end));
        const double t = static_cast<double>(b * per) / rate * 1e3;
        s.x.insert(s.x.end(), {t, t});
        s.y.insert(s.y.end(), {*lo * scale, *hi * scale});
    }
    s.width_px = 1.2;
    return s;
}

std::string traces_svg(const ReportContext &c, size_t f)
{
    const pipeline::Verification &v = *c.verification;
    Plot p;
    p.title = c.mode == "table" ? "focus " + std::to_string(v.foci[f].id) + " driven: displacement at every focus"
                                : "device drive: displacement at every focus";
    p.x = Axis("time (ms)");
    p.y = Axis("displacement (um)");
    p.width_px = 560;
    p.height_px = 300;
    p.legend = LegendPosition::top_right;
    const double thr = c.input->calibration.threshold_m * 1e6;
    const std::vector<std::vector<double>> &tr = v.traces[f];
    const double t_end = static_cast<double>(tr[0].size()) / v.trace_rate_hz * 1e3;
    const bool many = !few_foci(c);
    if (c.mode == "table" && many) { // a dense grid: the other foci as one curve, their largest |w|
        std::vector<double> other(tr[f].size(), 0.0);
        size_t others = 0;
        for (size_t g = 0; g < tr.size(); g++) {
            if (!pipeline::is_other_focus(*c.input, f, g, v.foci[f].lambda_half_m))
                continue;
            others++;
            for (size_t n = 0; n < other.size(); n++)
                other[n] = std::max(other[n], std::abs(tr[g][n]));
        }
        Series o = envelope_series("largest |w| at the " + std::to_string(others) + " foci beyond lambda/2", other,
                                   v.trace_rate_hz, 600, 1e6);
        o.color = Color{150, 150, 160};
        p.add(std::move(o));
    }
    for (size_t g = 0; g < tr.size(); g++) {
        if (c.mode == "table" && many && g != f)
            continue;
        Series s = envelope_series(c.mode == "table" && g == f ? "focus " + std::to_string(v.foci[g].id) + " (driven)"
                                                               : (g == 0 && c.mode == "table" ? "other foci" : ""),
                                   tr[g], v.trace_rate_hz, 600, 1e6);
        if (c.mode == "table") {
            s.color = g == f ? Color{214, 39, 40} : Color{150, 150, 160};
            if (g == f)
                s.width_px = 1.8;
        } else if (!many || v.foci[g].crosses_threshold) { // a dense grid: only the foci that cross are named
            s.label = "focus " + std::to_string(v.foci[g].id);
        } else {
            s.color = Color{150, 150, 160};
        }
        p.add(std::move(s));
    }
    if (c.mode == "table" && !many) // draw the driven focus on top
        std::rotate(p.series.begin() + static_cast<long>(f), p.series.begin() + static_cast<long>(f) + 1,
                    p.series.end());
    p.add(Series("threshold", {0, t_end}, {thr, thr}, LineStyle::dashed, Color{0, 0, 0}));
    p.add(Series("", {0, t_end}, {-thr, -thr}, LineStyle::dashed, Color{0, 0, 0}));
    return render_svg(p);
}

std::string dispersion_svg(const ReportContext &c)
{
    const auto &pp = c.input->plate->params();
    Plot p;
    p.title = "A0 wavelength, " + pp.material.name + " " + num(pp.thickness_m * 1e3) + " mm";
    p.x = Axis("frequency (Hz)", AxisScale::log);
    p.y = Axis("wavelength (mm)", AxisScale::log);
    p.width_px = 560;
    p.height_px = 320;
    std::vector<double> f, exact, kirch;
    const double f_hi = 4 * c.input->pulse.centre_hz;
    for (double x = 20; x <= f_hi; x *= 1.05) {
        f.push_back(x);
        exact.push_back(physics::a0_wavelength(pp.material, pp.thickness_m, x) * 1e3);
        kirch.push_back(physics::kirchhoff_phase_velocity(pp.material, pp.thickness_m, x) / x * 1e3);
    }
    p.add(Series("A0 (Rayleigh-Lamb)", f, exact));
    p.add(Series("Kirchhoff", f, kirch, LineStyle::dashed));
    const double fc = c.input->pulse.centre_hz;
    p.add(Series("pulse centre", {fc, fc}, {exact.back(), exact.front()}, LineStyle::dotted, Color{0, 0, 0}));
    return render_svg(p);
}

} // namespace

void write_html_report(const std::string &dir, const ReportContext &c)
{
    make_dir(dir);
    const pipeline::CalibrationInput &in = *c.input;
    const pipeline::Verification &v = *c.verification;
    const std::vector<size_t> shown = shown_foci(c);
    std::ostringstream h;
    char date[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    h << "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>calibration report: "
      << canvas::xml_escape(in.scene_name)
      << "</title><style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222}"
         "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
         "th{background:#f4f4f4}.ok{color:#17803d}.bad{color:#c0262d;font-weight:bold}"
         ".grid{display:flex;flex-wrap:wrap;gap:12px}.cell{border:1px solid #ddd;padding:6px}"
         "figcaption{font-size:0.9em;color:#555}</style></head><body>";
    h << "<h1>Calibration report: " << canvas::xml_escape(in.scene_name) << "</h1><p>Scene <code>"
      << canvas::xml_escape(c.scene_path) << "</code> (" << canvas::xml_escape(in.scene_hash) << "), table <code>"
      << canvas::xml_escape(c.table_path) << "</code>, " << date << ". Plate " << num(in.plate->params().size_x_m * 1e3)
      << " x " << num(in.plate->params().size_y_m * 1e3) << " x " << num(in.plate->params().thickness_m * 1e3, 2)
      << " mm " << canvas::xml_escape(in.plate->params().material.name) << ", grid " << in.plate->grid().nx << " x "
      << in.plate->grid().ny << " cells of " << num(in.plate->grid().h * 1e3) << " mm. Exciter force at full scale "
      << num(in.exciters.force_full_scale_n) << " N, threshold " << num(in.calibration.threshold_m * 1e6) << " um.";
    if (c.result)
        h << " Run time " << num(c.total_s, 3) << " s (simulation " << num(c.result->times.simulation_s, 2)
          << " s, search " << num(c.result->times.search_s, 2) << " s, signals " << num(c.result->times.signals_s, 2)
          << " s, verification " << num(c.result->times.verification_s, 2) << " s), peak memory "
          << num(c.peak_rss_mb, 3) << " MB.";
    h << "</p>";
    if (c.mode == "table" && !v.foci.empty()) { // the verdict first: what the exit status says
        const pipeline::VerdictSummary vs = pipeline::summarize_verdict(v.foci);
        h << "<p class='" << (vs.all_pass() ? "ok" : "bad") << "'>Verdict (" << v.foci[vs.worst].verdict_scope()
          << ", all times): " << vs.passing << " of " << vs.total << " foci pass: each crosses the threshold and "
          << "nothing farther than lambda/2 from it reaches the threshold."
          << (vs.all_pass() ? "" : " The failing foci say why in the metrics table below.") << "</p>";
    }

    h << "<h2>Layout</h2><figure>" << layout_svg(c)
      << "<figcaption>Plate, active area (green dashes), candidate sites (grey dots), the regular symmetric pattern "
         "(blue squares), the chosen exciters (red squares, channel numbers) and the foci (red, dashed circle of "
         "diameter lambda/2).</figcaption></figure>";
    if (c.result) {
        const pipeline::PlacementReport &p = c.result->placement;
        h << "<h2>Placement</h2><table><tr><th>pattern</th><th>predicted worst-case contrast (dB)</th>"
             "<th>distance variety (seed criterion)</th></tr><tr><td style='text-align:left'>regular symmetric</td><td>"
          << (p.regular.empty() ? "-" : num(p.regular_contrast_db)) << "</td><td>"
          << (p.regular.empty() ? "-" : num(p.regular_variety))
          << "</td></tr><tr><td style='text-align:left'>chosen</td><td>" << num(p.chosen_contrast_db) << "</td><td>"
          << num(p.chosen_variety) << "</td></tr></table><p>" << p.sites.size() << " candidate sites, " << p.evaluations
          << " placements evaluated, " << p.simulations << " simulations: "
          << (p.focus_subset.size() == v.foci.size()
                  ? "every focus weighed"
                  : std::to_string(p.focus_subset.size()) + " of the " + std::to_string(v.foci.size()) +
                        " foci weighed (farthest-point subset, ringed in the layout; every focus within " +
                        num(p.subset_cover_m * 1e3) + " mm of one)")
          << (p.probe_rows.empty()
                  ? ""
                  : ", contrast also checked at " + std::to_string(p.probe_rows.size()) + " probe points")
          << ".</p>";
    }
    h << "<h2>Metrics</h2><table><tr><th>focus</th><th>x (mm)</th><th>y (mm)</th><th>peak (um)</th>";
    if (c.mode == "table")
        h << "<th>max at other foci (um)</th><th>contrast over the other foci (dB)</th><th>spot diameter (mm)</th>"
             "<th>lambda/2 (mm)</th><th>field contrast at the focus instant (dB)</th>"
             "<th>whole-area contrast, all times (dB)</th><th>lead time (ms)</th><th>perceived offset (mm)</th>"
             "<th>crosses threshold</th><th>others below</th><th>whole area below</th>"
             "<th>safe range (dB re the stored level)</th><th>verdict</th>";
    else
        h << "<th>peak time (ms)</th><th>crosses threshold</th>";
    h << "</tr>";
    auto yes = [](bool b) {
        return b ? std::string("<td class='ok'>yes</td>") : std::string("<td class='bad'>no</td>");
    };
    for (const FocusMetrics &m : v.foci) {
        h << "<tr><td>" << m.id << "</td><td>" << num(m.at.x_m * 1e3) << "</td><td>" << num(m.at.y_m * 1e3)
          << "</td><td>" << num(m.peak_m * 1e6) << "</td>";
        if (c.mode == "table")
            h << "<td>" << num(m.max_other_foci_m * 1e6) << "</td><td>" << num(m.other_foci_contrast_db) << "</td><td>"
              << num(m.spot_diameter_m * 1e3) << "</td><td>" << num(m.lambda_half_m * 1e3) << "</td><td>"
              << num(m.field_contrast_db) << "</td><td>" << (m.whole_area ? num(m.whole_area_contrast_db) : "-")
              << "</td><td>" << num(m.lead_time_s * 1e3) << "</td><td>"
              << (m.whole_area ? num(m.perceived_offset_distance_m * 1e3) : "-") << "</td>" << yes(m.crosses_threshold)
              << yes(m.others_below_threshold)
              << (m.whole_area ? yes(m.whole_area_below_threshold) : std::string("<td>-</td>")) << "<td>"
              << pipeline::safe_range_text(m.gain_range(c.input->calibration.threshold_m)) << "</td>"
              << (m.passes() ? std::string("<td class='ok'>pass</td>")
                             : "<td class='bad'>fails: " +
                                   canvas::xml_escape(m.failure(c.input->calibration.threshold_m)) + "</td>");
        else
            h << "<td>" << num(m.lead_time_s * 1e3) << "</td>" << yes(m.crosses_threshold);
        h << "</tr>";
    }
    h << "</table>";
    if (c.mode == "table")
        h << "<p>Safe range: the gains, in dB relative to the level the table stores, at which the focus passes the "
             "verdict: from the gain at which its focal peak reaches the threshold up to (not including) the gain at "
             "which something the verdict judges beyond lambda/2 reaches it. The table stores it per focus. "
             "Unbounded: nothing judged beyond lambda/2 moves; none: no gain passes.</p>";
    h << drive_design_html(c);
    if (c.mode == "table") {
        h << field_sections_html(c, shown);
        if (c.result && c.result->tolerance)
            h << tolerance_html(*c.result->tolerance, v.foci.size());
    }
    h << "<h2>Displacement at the foci</h2><div class='grid'>";
    if (c.mode != "table")
        h << "<figure class='cell'>" << traces_svg(c, 0) << "</figure>";
    else
        for (size_t f : shown)
            if (f < v.traces.size())
                h << "<figure class='cell'>" << traces_svg(c, f) << "</figure>";
    h << "</div>";
    if (c.modes)
        h << modes_html(*c.modes, *in.plate);
    h << "<h2>Dispersion</h2><figure>" << dispersion_svg(c) << "</figure></body></html>\n";
    io::write_file_atomic(dir + "/index.html", h.str());
}

} // namespace calib::report
