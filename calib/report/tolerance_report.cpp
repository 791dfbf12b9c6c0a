#include "report/tolerance_report.h"

#include "io/format.h"

#include <algorithm>
#include <sstream>

namespace calib::report {

namespace {

using io::fmt;
using pipeline::CaseFigures;

toml::table figures_json(const CaseFigures &c)
{
    return toml::table{{"worst_whole_area_contrast_db", c.worst_whole_area_contrast_db},
                       {"worst_focus", static_cast<int64_t>(c.worst_focus_id)},
                       {"min_peak_m", c.min_peak_m},
                       {"max_peak_m", c.max_peak_m},
                       {"max_perceived_offset_m", c.max_offset_m},
                       {"max_lead_time_s", c.max_lead_time_s},
                       {"foci_passing", static_cast<int64_t>(c.foci_passing)},
                       {"foci_failing", static_cast<int64_t>(c.foci_failing)},
                       {"area_crossings", static_cast<int64_t>(c.area_crossings)},
                       {"peak_per_drive_energy", c.peak_per_energy}};
}

std::string line(const std::string &name, const CaseFigures &c, std::size_t foci)
{
    return (name + std::string(34, ' ')).substr(0, std::max<std::size_t>(34, name.size())) +
           fmt(" %7.2f dB", c.worst_whole_area_contrast_db) + fmt("  peak %5.2f", c.min_peak_m * 1e6) +
           fmt("-%5.2f um", c.max_peak_m * 1e6) + fmt("  offset %5.1f mm", c.max_offset_m * 1e3) + "  verdict: pass " +
           std::to_string(c.foci_passing) + "/" + std::to_string(foci) + ", area crosses at " +
           std::to_string(c.area_crossings) + "\n";
}

std::string html_row(const std::string &name, const CaseFigures &c, std::size_t foci, bool bold)
{
    const char *o = bold ? "<b>" : "", *e = bold ? "</b>" : "";
    std::ostringstream h;
    h << "<tr><td style='text-align:left'>" << o << name << e << "</td><td>"
      << fmt("%.2f", c.worst_whole_area_contrast_db) << " (" << c.worst_focus_id << ")</td><td>"
      << fmt("%.2f", c.min_peak_m * 1e6) << " - " << fmt("%.2f", c.max_peak_m * 1e6) << "</td><td>"
      << fmt("%.1f", c.max_offset_m * 1e3) << "</td><td>" << fmt("%.1f", c.max_lead_time_s * 1e3) << "</td><td class='"
      << (c.foci_passing == foci ? "ok" : "bad") << "'>" << c.foci_passing << " / " << foci << "</td><td>"
      << c.area_crossings << "</td></tr>";
    return h.str();
}

} // namespace

toml::table tolerance_json(const pipeline::ToleranceReport &r)
{
    toml::table t{{"nominal", figures_json(r.nominal)}, {"worst", figures_json(r.worst)}, {"seconds", r.seconds}};
    toml::array cases;
    for (const pipeline::ToleranceCase &c : r.cases) {
        toml::table x = figures_json(c.table);
        x.insert("name", c.perturbation.name);
        x.insert("factor", c.perturbation.factor);
        if (c.nominal_design)
            x.insert("plain_design", figures_json(*c.nominal_design));
        x.insert("speed_ratio", c.speed_ratio);
        if (c.compensated)
            x.insert("compensated", figures_json(*c.compensated));
        if (c.nominal_design_compensated)
            x.insert("plain_design_compensated", figures_json(*c.nominal_design_compensated));
        cases.push_back(std::move(x));
    }
    t.insert("cases", std::move(cases));
    if (r.compensated_worst)
        t.insert("compensated_worst", figures_json(*r.compensated_worst));
    if (r.nominal_design_compensated_worst)
        t.insert("plain_compensated_worst", figures_json(*r.nominal_design_compensated_worst));
    if (r.nominal_design) {
        toml::array members;
        for (const std::string &m : r.ensemble)
            members.push_back(m);
        t.insert("robust", toml::table{{"ensemble", std::move(members)},
                                       {"ensemble_seconds", r.ensemble_seconds},
                                       {"plain_nominal", figures_json(*r.nominal_design)},
                                       {"plain_worst", figures_json(*r.nominal_design_worst)}});
    }
    return t;
}

std::string tolerance_text(const pipeline::ToleranceReport &r, std::size_t foci)
{
    std::string s = "tolerance box: " + std::to_string(r.cases.size()) + " plates verified in " +
                    fmt("%.1f s", r.seconds) + " (worst-focus whole-area contrast, peak, offset, verdict)\n";
    s += line("  nominal plate", r.nominal, foci);
    s += line("  worst over the box", r.worst, foci);
    if (r.compensated_worst)
        s += line("  worst, speed compensated", *r.compensated_worst, foci);
    if (r.nominal_design) {
        s += line("  plain design, nominal plate", *r.nominal_design, foci);
        s += line("  plain design, worst over the box", *r.nominal_design_worst, foci);
        if (r.nominal_design_compensated_worst)
            s += line("  plain design, worst, compensated", *r.nominal_design_compensated_worst, foci);
        s += "  robust design over " + std::to_string(r.ensemble.size() + 1) +
             " plates: " + fmt("%.1f s", r.ensemble_seconds) + ", peak per drive energy " +
             fmt("%+.1f %%", 100 * (r.nominal.peak_per_energy / r.nominal_design->peak_per_energy - 1)) +
             " against the plain design\n";
    }
    return s;
}

std::string tolerance_html(const pipeline::ToleranceReport &r, std::size_t foci)
{
    std::ostringstream h;
    h << "<h2>Tolerance box</h2><p>The table verified on " << r.cases.size()
      << " perturbed plates, each from its own transfer matrix (" << fmt("%.1f", r.seconds)
      << " s). Contrast: the worst focus's whole-area contrast over all times (its id in brackets).";
    if (r.nominal_design)
        h << " The table is the robust design over " << r.ensemble.size() + 1 << " plates ("
          << fmt("%.1f", r.ensemble_seconds) << " s); the plain design is shown beside it. Peak per drive energy "
          << fmt("%+.1f %%", 100 * (r.nominal.peak_per_energy / r.nominal_design->peak_per_energy - 1))
          << " against the plain design.";
    if (r.compensated_worst)
        h << " Speed compensation: the device plays each panel at its speed ratio (the panel's kappa over the "
             "nominal plate's; hapticd [panel]); the rows marked <i>compensated</i> are the table stretched by it.";
    h << "</p><table><tr><th>plate</th><th>worst-focus whole-area contrast (dB)</th><th>peak (um)</th>"
         "<th>perceived offset (mm)</th><th>lead (ms)</th><th>foci passing the verdict</th><th>area crosses "
         "at</th></tr>";
    h << html_row("nominal", r.nominal, foci, false);
    if (r.nominal_design)
        h << html_row("nominal, plain design", *r.nominal_design, foci, false);
    for (const pipeline::ToleranceCase &c : r.cases) {
        h << html_row(c.perturbation.name, c.table, foci, false);
        if (c.nominal_design)
            h << html_row(c.perturbation.name + ", plain design", *c.nominal_design, foci, false);
        const std::string at = fmt(", compensated x%.4f", c.speed_ratio);
        if (c.compensated)
            h << html_row(c.perturbation.name + at, *c.compensated, foci, false);
        if (c.nominal_design_compensated)
            h << html_row(c.perturbation.name + ", plain design" + at, *c.nominal_design_compensated, foci, false);
    }
    h << html_row("worst over the box", r.worst, foci, true);
    if (r.nominal_design_worst)
        h << html_row("worst over the box, plain design", *r.nominal_design_worst, foci, true);
    if (r.compensated_worst)
        h << html_row("worst over the box, speed compensated", *r.compensated_worst, foci, true);
    if (r.nominal_design_compensated_worst)
        h << html_row("worst over the box, plain design, speed compensated", *r.nominal_design_compensated_worst, foci,
                      true);
    h << "</table>";
    return h.str();
}

} // namespace calib::report
