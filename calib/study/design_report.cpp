#include "study/design_report.h"

#include "io/atomic_file.h"
#include "io/format.h"
#include "report/plot.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <optional>
#include <sstream>
#include <tuple>

namespace calib::study {

namespace {

using io::fmt;

std::string csv_field(const std::string &s)
{
    if (s.find_first_of(",\"\n") == std::string::npos)
        return s;
    std::string q = "\"";
    for (char c : s)
        q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
}

std::string inputs_csv(const CaseResult &r)
{
    return std::to_string(r.index) + "," + r.id + "," + csv_field(r.material) + "," + fmt("%.9g", r.thickness_m) + "," +
           csv_field(r.edges) + "," + std::to_string(r.exciters) + "," + r.criterion + "," + std::to_string(r.seed) +
           "," + fmt("%.9g", r.pulse_centre_hz) + "," + fmt("%.9g", r.pulse_cycles);
}

const char *inputs_header = "case,id,material,thickness_m,edges,exciters,criterion,seed,pulse_centre_hz,pulse_cycles";

// A case's label from the inputs that vary across the sweep, except `skip`.
struct Labeler {
    bool material = false, thickness = false, edges = false, exciters = false, criterion = false, seed = false,
         centre = false, cycles = false;
    explicit Labeler(const std::vector<CaseResult> &c)
    {
        for (const CaseResult &r : c) {
            const CaseResult &a = c.front();
            material |= r.material != a.material;
            thickness |= r.thickness_m != a.thickness_m;
            edges |= r.edges != a.edges;
            exciters |= r.exciters != a.exciters;
            criterion |= r.criterion != a.criterion;
            seed |= r.seed != a.seed;
            centre |= r.pulse_centre_hz != a.pulse_centre_hz;
            cycles |= r.pulse_cycles != a.pulse_cycles;
        }
    }
    std::string operator()(const CaseResult &r, bool with_exciters, bool with_centre) const
    {
        std::string s;
        auto add = [&](const std::string &x) { s += (s.empty() ? "" : ", ") + x; };
        if (material)
            add(r.material);
        if (thickness)
            add(fmt("%g mm", r.thickness_m * 1e3));
        if (edges)
            add(r.edges);
        if (exciters && with_exciters)
            add(std::to_string(r.exciters) + " exciters");
        if (criterion)
            add(r.criterion);
        if (seed)
            add("seed " + std::to_string(r.seed));
        if (centre && with_centre)
            add(fmt("%g Hz", r.pulse_centre_hz));
        if (cycles)
            add(fmt("%g cycles", r.pulse_cycles));
        return s.empty() ? "all cases" : s;
    }
};

// One series per label, x sorted; points of failed cases left out.
void add_series(report::Plot &p, const std::vector<CaseResult> &cases,
                const std::function<std::string(const CaseResult &)> &label,
                const std::function<double(const CaseResult &)> &x, const std::function<double(const CaseResult &)> &y)
{
    std::vector<std::string> order;
    std::map<std::string, std::vector<std::pair<double, double>>> pts;
    for (const CaseResult &r : cases) {
        if (!r.ran)
            continue;
        const std::string l = label(r);
        if (!pts.count(l))
            order.push_back(l);
        pts[l].emplace_back(x(r), y(r));
    }
    for (const std::string &l : order) {
        auto v = pts[l];
        std::stable_sort(v.begin(), v.end(), [](auto &a, auto &b) { return a.first < b.first; });
        report::Series s;
        s.label = l;
        for (auto [a, b] : v) {
            s.x.push_back(a);
            s.y.push_back(std::isfinite(b) ? b : NAN);
        }
        s.markers = true;
        p.add(std::move(s));
    }
}

void write_plots(const std::vector<CaseResult> &cases, const std::string &dir)
{
    const bool any = std::any_of(cases.begin(), cases.end(), [](const CaseResult &r) { return r.ran; });
    if (!any)
        return;
    const Labeler label(cases);
    report::Plot c;
    c.title = "Worst-focus contrast against exciter count";
    c.x = {"exciters"};
    c.y = {"worst contrast (dB)"};
    c.legend = report::LegendPosition::bottom_right;
    add_series(
        c, cases, [&](const CaseResult &r) { return label(r, false, true); },
        [](const CaseResult &r) { return double(r.exciters); },
        [](const CaseResult &r) { return r.worst_contrast_db; });
    report::Plot s;
    s.title = "Largest focal spot against pulse centre frequency";
    s.x = {"pulse centre (Hz)"};
    s.y = {"largest half-peak spot diameter (mm)"};
    add_series(
        s, cases, [&](const CaseResult &r) { return label(r, true, false); },
        [](const CaseResult &r) { return r.pulse_centre_hz; }, [](const CaseResult &r) { return r.max_spot_m * 1e3; });
    for (const char *ext : {".svg", ".png"}) {
        report::write_plot(c, dir + "/contrast_vs_exciters" + ext);
        report::write_plot(s, dir + "/spot_vs_frequency" + ext);
    }
}

bool meets_criterion(const CaseResult &r) { return r.ran && r.foci > 0 && r.foci_meeting_criterion == r.foci; }

bool within(const Sweep &s, const CaseResult &r)
{
    const Constraints &c = s.constraints;
    return r.ran && (!c.min_contrast_db || r.worst_contrast_db >= *c.min_contrast_db) &&
           (!c.max_spot_m || r.max_spot_m <= *c.max_spot_m) &&
           (!c.max_lead_time_s || r.max_lead_time_s <= *c.max_lead_time_s) &&
           (!c.max_exciters || r.exciters <= *c.max_exciters);
}

// The first case (in case order) that is best by `better`, among those `ok`.
const CaseResult *best(const std::vector<CaseResult> &cases, const std::function<bool(const CaseResult &)> &ok,
                       const std::function<bool(const CaseResult &, const CaseResult &)> &better)
{
    const CaseResult *b = nullptr;
    for (const CaseResult &r : cases)
        if (ok(r) && (!b || better(r, *b)))
            b = &r;
    return b;
}

std::string figures_md(const CaseResult &r)
{
    return fmt("%.1f dB", r.worst_contrast_db) + " | " + std::to_string(r.foci_meeting_criterion) + "/" +
           std::to_string(r.foci) + " | " + fmt("%.0f mm", r.max_spot_m * 1e3) + " | " +
           fmt("%.1f ms", r.max_lead_time_s * 1e3) + " | " + fmt("%.3g", r.min_peak_per_sqrt_energy);
}

std::string inputs_md(const CaseResult &r)
{
    return std::to_string(r.index) + " | " + r.material + " | " + fmt("%g", r.thickness_m * 1e3) + " | " + r.edges +
           " | " + std::to_string(r.exciters) + " | " + r.criterion + " | " + std::to_string(r.seed) + " | " +
           fmt("%g", r.pulse_centre_hz) + " | " + fmt("%g", r.pulse_cycles);
}

const char *table_head =
    "| case | material | thickness (mm) | edges | exciters | criterion | seed | centre (Hz) | cycles | worst contrast "
    "| "
    "foci meeting the criterion | largest spot | longest lead | peak / sqrt(drive energy) (m/(N s^0.5)) |\n"
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";

} // namespace

std::string design_csv(const std::vector<CaseResult> &cases)
{
    std::ostringstream o;
    o << inputs_header
      << ",status,foci,foci_meeting_criterion,worst_contrast_db,min_peak_m,min_peak_per_sqrt_energy_m_per_N_sqrt_s,"
         "max_spot_m,max_lead_time_s,note\n";
    for (const CaseResult &r : cases) {
        o << inputs_csv(r) << "," << (r.ran ? "ok" : "refused") << ",";
        if (r.ran)
            o << r.foci << "," << r.foci_meeting_criterion << "," << fmt("%.9g", r.worst_contrast_db) << ","
              << fmt("%.9g", r.min_peak_m) << "," << fmt("%.9g", r.min_peak_per_sqrt_energy) << ","
              << fmt("%.9g", r.max_spot_m) << "," << fmt("%.9g", r.max_lead_time_s) << ",";
        else
            o << ",,,,,,,";
        o << csv_field(r.note) << "\n";
    }
    return o.str();
}

std::string timing_csv(const std::vector<CaseResult> &cases)
{
    std::ostringstream o;
    o << "case,id,rank,wall_s,simulation_s,search_s,verification_s,peak_rss_mb\n";
    for (const CaseResult &r : cases)
        o << r.index << "," << r.id << "," << r.rank << "," << fmt("%.3f", r.wall_s) << ","
          << fmt("%.3f", r.simulation_s) << "," << fmt("%.3f", r.search_s) << "," << fmt("%.3f", r.verification_s)
          << "," << fmt("%.1f", r.peak_rss_mb) << "\n";
    return o.str();
}

std::string design_summary(const Sweep &sweep, const std::vector<CaseResult> &cases)
{
    std::ostringstream o;
    const size_t ran = static_cast<size_t>(std::count_if(cases.begin(), cases.end(), [](auto &r) { return r.ran; }));
    o << "# Design study: " << sweep.name << "\n\n"
      << "Base scene `" << sweep.base_path << "`, " << cases.size() << " cases (" << ran << " calibrated and verified, "
      << cases.size() - ran << " refused). Figures are the worst over the foci: contrast is the focal peak over the "
      << "largest displacement at any other focus at any time; a focus meets the criterion when it crosses the "
      << "threshold while every other focus stays below it. Wall time and memory are in `timing.csv`.\n\n";

    auto higher_contrast = [](const CaseResult &a, const CaseResult &b) {
        return a.worst_contrast_db > b.worst_contrast_db;
    };
    auto fewer_exciters = [](const CaseResult &a, const CaseResult &b) {
        return a.exciters != b.exciters ? a.exciters < b.exciters : a.worst_contrast_db > b.worst_contrast_db;
    };
    auto ran_ok = [](const CaseResult &r) { return r.ran; };
    struct Pick {
        std::string question;
        const CaseResult *r;
    };
    std::vector<Pick> picks = {
        {"Highest worst-focus contrast", best(cases, ran_ok, higher_contrast)},
        {"Fewest exciters with every focus meeting the criterion", best(cases, meets_criterion, fewer_exciters)},
        {"Smallest largest spot", best(cases, ran_ok, [](auto &a, auto &b) { return a.max_spot_m < b.max_spot_m; })},
        {"Shortest lead time (touch to focal peak, drive part)",
         best(cases, ran_ok, [](auto &a, auto &b) { return a.max_lead_time_s < b.max_lead_time_s; })},
        {"Most focal peak per drive energy",
         best(cases, ran_ok, [](auto &a, auto &b) { return a.min_peak_per_sqrt_energy > b.min_peak_per_sqrt_energy; })},
    };
    const Constraints &c = sweep.constraints;
    if (c.min_contrast_db || c.max_spot_m || c.max_lead_time_s || c.max_exciters) {
        std::string lim;
        auto add = [&](const std::string &x) { lim += (lim.empty() ? "" : ", ") + x; };
        if (c.min_contrast_db)
            add(fmt("contrast >= %g dB", *c.min_contrast_db));
        if (c.max_spot_m)
            add(fmt("spot <= %g mm", *c.max_spot_m * 1e3));
        if (c.max_lead_time_s)
            add(fmt("lead time <= %g ms", *c.max_lead_time_s * 1e3));
        if (c.max_exciters)
            add("exciters <= " + std::to_string(*c.max_exciters));
        auto in = [&](const CaseResult &r) { return within(sweep, r); };
        picks.push_back({"Within the constraints (" + lim + "): fewest exciters", best(cases, in, fewer_exciters)});
        picks.push_back({"Within the constraints (" + lim + "): highest contrast", best(cases, in, higher_contrast)});
    }
    o << "## Best case per question\n\n"
      << "| question | case | material | thickness (mm) | edges | exciters | criterion | seed | centre (Hz) | cycles | "
         "worst contrast | foci meeting the criterion | largest spot | longest lead | peak / sqrt(drive energy) |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const Pick &p : picks) {
        if (p.r)
            o << "| " << p.question << " | " << inputs_md(*p.r) << " | " << figures_md(*p.r) << " |\n";
        else
            o << "| " << p.question << " | none |  |  |  |  |  |  |  |  |  |  |  |  |  |\n";
    }
    o << "\n## Every case\n\n" << table_head;
    for (const CaseResult &r : cases) {
        o << "| " << inputs_md(r) << " | ";
        if (r.ran)
            o << figures_md(r) << " |\n";
        else
            o << "refused: " << r.note << " |  |  |  |  |\n";
    }
    o << "\nPlots: `contrast_vs_exciters.svg` (one line per configuration), `spot_vs_frequency.svg`.\n";
    return o.str();
}

std::string write_design_report(const Sweep &sweep, const std::vector<CaseResult> &cases, const std::string &dir)
{
    io::write_file_atomic(dir + "/design.csv", design_csv(cases));
    io::write_file_atomic(dir + "/timing.csv", timing_csv(cases));
    write_plots(cases, dir);
    const std::string md = design_summary(sweep, cases);
    io::write_file_atomic(dir + "/summary.md", md);
    return md;
}

} // namespace calib::study
