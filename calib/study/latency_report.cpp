// The latency study's files: CSV, plots (report/plot.h), markdown table.
#include "study/latency.h"

#include "io/atomic_file.h"
#include "io/format.h"
#include "report/plot.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

namespace calib::study {

namespace {

using io::fmt;

const char *name(pipeline::DriveMethod m)
{
    return m == pipeline::DriveMethod::inverse_filter ? "inverse_filter" : "time_reversal";
}

// One curve per method (and regularization) over the swept lead times.
void add_curves(report::Plot &p, const LatencyResult &r, double (*get)(const LatencyRow &))
{
    std::vector<std::pair<std::string, report::Series>> curves;
    for (const LatencyRow &x : r.rows) {
        if (x.scene_default || !x.error.empty())
            continue;
        const bool inv = x.method == pipeline::DriveMethod::inverse_filter;
        const std::string label = inv ? "inverse filter, eps " + fmt("%g", x.regularization) : "time reversal";
        auto it = std::find_if(curves.begin(), curves.end(), [&](const auto &c) { return c.first == label; });
        if (it == curves.end()) {
            curves.push_back({label, report::Series(label, {}, {})});
            curves.back().second.markers = true;
            it = curves.end() - 1;
        }
        it->second.x.push_back(x.lead_target_s * 1e3);
        it->second.y.push_back(get(x));
    }
    for (auto &c : curves)
        p.add(std::move(c.second));
}

// Medians of a list (NaN when empty).
double median(std::vector<double> v)
{
    if (v.empty())
        return NAN;
    std::sort(v.begin(), v.end());
    const std::size_t n = v.size();
    return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

std::string ids(const std::vector<std::size_t> &set, const std::vector<uint32_t> &id_of)
{
    std::string s;
    for (std::size_t f : set)
        s += (s.empty() ? "" : "+") + std::to_string(id_of[f]);
    return s;
}

// The joint designs against the superposition: every set of every case in
// multitouch.csv, a scatter of the margins, a summary table (markdown).
std::string write_joint(const LatencyResult &r, const std::string &dir)
{
    std::ostringstream csv, md;
    csv << "method,regularization,scene_default_lead,lead_time_target_s,foci,design,gain,weakest_focus_m,"
           "max_elsewhere_m,elsewhere_x_m,elsewhere_y_m,margin_m,ok,set_contrast_db\n";
    md << "\n**Several fingers: the table's single foci superposed (the firmware's mix) against a drive designed "
          "for the set** (the inverse filter with every touched focus a target, the same lead time and "
          "regularization, under the superposition's budget: its energy, full scale, no focus above the "
          "scene's amplitude; pipeline/multitouch.h). Gains are medians over the sets, joint minus superposed.\n\n"
       << "| case | sets | failing: superposed | failing: joint | worst margin (um): superposed | worst margin "
          "(um): joint | weakest focus gain (dB) | set contrast gain (dB) | sets the joint design rescues | "
          "sets it loses |\n|---|---|---|---|---|---|---|---|---|---|\n";
    report::Plot p;
    p.title = r.scene_name + ": several fingers, joint design against superposition";
    p.x = {"superposed: margin under threshold (um)"};
    p.y = {"joint design: margin under threshold (um)"};
    p.legend = report::LegendPosition::bottom_right;
    double lo = INFINITY, hi = -INFINITY;
    bool any = false;
    for (const LatencyRow &x : r.rows) {
        const std::string lead = fmt("%.0f ms", x.lead_target_s * 1e3) + (x.scene_default ? " (scene)" : "");
        for (std::size_t size : {2u, 3u}) {
            std::size_t n = 0, fail_s = 0, fail_j = 0, rescued = 0, lost = 0;
            double worst_s = INFINITY, worst_j = INFINITY;
            std::vector<double> peak_gain, contrast_gain;
            report::Series dots(std::string(size == 2 ? "pairs" : "triples") + ", " + lead, {}, {},
                                report::LineStyle::none);
            dots.markers = true;
            for (const pipeline::MultiTouchCase &c : x.sets) {
                if (!c.has_joint || c.foci.size() != size)
                    continue;
                n++;
                for (const auto *v : {&c.superposed, &c.joint}) {
                    csv << name(x.method) << ',' << x.regularization << ',' << (x.scene_default ? 1 : 0) << ','
                        << x.lead_target_s << ',' << ids(c.foci, r.focus_ids) << ','
                        << (v == &c.joint ? "joint" : "superposed") << ',' << v->gain << ',' << v->min_focus_peak_m
                        << ',' << v->max_elsewhere_m << ',' << v->elsewhere_at.x_m << ',' << v->elsewhere_at.y_m << ','
                        << v->margin_m << ',' << (v->ok ? 1 : 0) << ',' << v->contrast_db() << '\n';
                }
                fail_s += !c.superposed.ok;
                fail_j += !c.joint.ok;
                rescued += !c.superposed.ok && c.joint.ok;
                lost += c.superposed.ok && !c.joint.ok;
                worst_s = std::min(worst_s, c.superposed.margin_m);
                worst_j = std::min(worst_j, c.joint.margin_m);
                peak_gain.push_back(20 * std::log10(c.joint.min_focus_peak_m / c.superposed.min_focus_peak_m));
                contrast_gain.push_back(c.joint.contrast_db() - c.superposed.contrast_db());
                dots.x.push_back(c.superposed.margin_m * 1e6);
                dots.y.push_back(c.joint.margin_m * 1e6);
                lo = std::min({lo, c.superposed.margin_m * 1e6, c.joint.margin_m * 1e6});
                hi = std::max({hi, c.superposed.margin_m * 1e6, c.joint.margin_m * 1e6});
            }
            if (!n)
                continue;
            any = true;
            p.add(std::move(dots));
            md << "| inverse filter, eps " << fmt("%g", x.regularization) << ", " << lead << ", "
               << (size == 2 ? "pairs" : "triples") << " | " << n << " | " << fail_s << " | " << fail_j << " | "
               << fmt("%+.2f", worst_s * 1e6) << " | " << fmt("%+.2f", worst_j * 1e6) << " | "
               << fmt("%+.2f", median(peak_gain)) << " | " << fmt("%+.2f", median(contrast_gain)) << " | " << rescued
               << " | " << lost << " |\n";
        }
    }
    if (!any) { // no joint designs: nothing of an earlier run's may stay beside this one
        std::error_code ec;
        for (const char *f : {"/multitouch.csv", "/multitouch.svg", "/multitouch.png"})
            std::filesystem::remove(dir + f, ec);
        return {};
    }
    p.add(report::Series("joint = superposed", {lo, hi}, {lo, hi}, report::LineStyle::dashed));
    io::write_file_atomic(dir + "/multitouch.csv", csv.str());
    report::write_plot(p, dir + "/multitouch.svg");
    report::write_plot(p, dir + "/multitouch.png");
    return md.str();
}

} // namespace

std::string write_latency_report(const LatencyResult &r, const std::string &dir)
{
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        throw std::runtime_error(dir + ": cannot create the report directory: " + ec.message());
    std::ostringstream csv;
    csv << "scene,method,regularization,scene_default_lead,lead_time_target_s,lead_time_measured_s,"
           "worst_whole_area_contrast_db,worst_other_foci_contrast_db,min_peak_m,margin_under_threshold_m,"
           "all_cross,all_alone,min_peak_per_root_energy,max_drive_energy_n2s,max_out_of_band_fraction,pairs,pairs_"
           "failing,"
           "worst_pair,worst_pair_margin_m,triples,triples_failing,worst_triple,worst_triple_margin_m,max_sound_"
           "exposure_dba,"
           "seconds,error\n";
    for (const LatencyRow &x : r.rows) {
        std::string err = x.error;
        std::replace(err.begin(), err.end(), ',', ';');
        std::replace(err.begin(), err.end(), '"', '\'');
        csv << r.scene_name << ',' << name(x.method) << ',' << x.regularization << ',' << (x.scene_default ? 1 : 0)
            << ',' << x.lead_target_s << ',' << x.lead_measured_s << ',' << x.worst_whole_area_db << ','
            << x.worst_other_foci_db << ',' << x.min_peak_m << ',' << x.margin_m << ',' << (x.all_cross ? 1 : 0) << ','
            << (x.all_alone ? 1 : 0) << ',' << x.min_peak_per_root_energy << ',' << x.max_energy_n2s << ','
            << x.max_out_of_band << ',' << x.pairs << ',' << x.pairs_failing << ',' << x.worst_pair[0] << '+'
            << x.worst_pair[1] << ',' << x.worst_pair_margin_m << ',' << x.triples << ',' << x.triples_failing << ','
            << x.worst_triple[0] << '+' << x.worst_triple[1] << '+' << x.worst_triple[2] << ','
            << x.worst_triple_margin_m << ',' << x.max_sound_dba << ',' << x.seconds << ",\"" << err << "\"\n";
    }
    io::write_file_atomic(dir + "/latency.csv", csv.str());

    report::Plot p;
    p.title = r.scene_name + ": worst whole-area contrast against lead time";
    p.x = {"lead time: playback start to focal peak (ms)"};
    p.y = {"worst whole-area contrast, all times (dB)"};
    p.legend = report::LegendPosition::bottom_right;
    add_curves(p, r, [](const LatencyRow &x) { return x.worst_whole_area_db; });
    if (!p.series.empty()) {
        report::write_plot(p, dir + "/latency.svg");
        report::write_plot(p, dir + "/latency.png");
    }
    report::Plot e;
    e.title = r.scene_name + ": focal peak per root drive energy (worst focus)";
    e.x = {"lead time: playback start to focal peak (ms)"};
    e.y = {"peak / sqrt(energy) (um / (N s^0.5))"};
    add_curves(e, r, [](const LatencyRow &x) { return x.min_peak_per_root_energy * 1e6; });
    if (!e.series.empty())
        report::write_plot(e, dir + "/latency-efficiency.svg");

    std::ostringstream md;
    md << "Scene `" << r.scene_file << "`: " << r.exciters.size() << " exciters (the scene's placement), plate "
       << "crossing " << fmt("%.1f ms", r.crossing_s * 1e3) << " (farthest exciter to farthest focus at the A0 group "
       << "velocity), threshold " << fmt("%.1f um", r.threshold_m * 1e6) << ".\n\n"
       << "An ideal focus (waves from every direction alike on an infinite lossless plate, nothing after) has "
       << "a whole-area contrast of " << fmt("%.1f dB", r.ceiling.target_db) << " for the pulse itself and "
       << fmt("%.1f dB", r.ceiling.autocorrelation_db) << " for time reversal's autocorrelation: its first ring, at "
       << fmt("%.0f mm", r.ceiling.target_ring_radius_m * 1e3) << ", is the diffraction limit of the criterion "
       << "(pipeline/focus_ceiling.h).\n\n"
       << "| method | lead target (ms) | lead measured (ms) | worst whole-area contrast (dB) | worst over other foci "
          "(dB) | min peak (um) | margin under threshold (um) | every focus crosses | crosses alone | peak per root "
          "energy (um/(N s^0.5)) | max drive energy (N^2 s) | max energy above band (%) | pairs failing | worst "
          "pair: margin (um) | triples failing | worst triple: margin (um) | loudest focus L_AE at 0.5 m (dB(A)) |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const LatencyRow &x : r.rows) {
        const bool inv = x.method == pipeline::DriveMethod::inverse_filter;
        md << "| " << (inv ? "inverse filter, eps " + fmt("%g", x.regularization) : std::string("time reversal"))
           << (x.scene_default ? " (scene window)" : "") << " | " << fmt("%.1f", x.lead_target_s * 1e3) << " | ";
        if (!x.error.empty()) {
            md << "failed: " << x.error << " ||||||||||||||| \n";
            continue;
        }
        md << fmt("%.1f", x.lead_measured_s * 1e3) << " | " << fmt("%.1f", x.worst_whole_area_db) << " | "
           << fmt("%.1f", x.worst_other_foci_db) << " | " << fmt("%.2f", x.min_peak_m * 1e6) << " | "
           << fmt("%+.2f", x.margin_m * 1e6) << " | " << (x.all_cross ? "yes" : "no") << " | "
           << (x.all_alone ? "yes" : "no") << " | " << fmt("%.3g", x.min_peak_per_root_energy * 1e6) << " | "
           << fmt("%.3g", x.max_energy_n2s) << " | " << fmt("%.2f", 100 * x.max_out_of_band) << " | "
           << (x.pairs ? std::to_string(x.pairs_failing) + " of " + std::to_string(x.pairs) : std::string("-")) << " | "
           << (x.pairs ? std::to_string(x.worst_pair[0]) + "+" + std::to_string(x.worst_pair[1]) + ": " +
                             fmt("%+.2f", x.worst_pair_margin_m * 1e6)
                       : std::string("-"))
           << " | "
           << (x.triples ? std::to_string(x.triples_failing) + " of " + std::to_string(x.triples) : std::string("-"))
           << " | "
           << (x.triples ? std::to_string(x.worst_triple[0]) + "+" + std::to_string(x.worst_triple[1]) + "+" +
                               std::to_string(x.worst_triple[2]) + ": " + fmt("%+.2f", x.worst_triple_margin_m * 1e6)
                         : std::string("-"))
           << " | " << fmt("%.1f", x.max_sound_dba) << " |\n";
    }
    md << write_joint(r, dir);
    io::write_file_atomic(dir + "/latency.md", md.str());
    return md.str();
}

} // namespace calib::study
