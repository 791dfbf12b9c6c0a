// `calibgen dispersion`: Lamb/SH mode table (CSV on stdout) and an optional
// dispersion diagram. See docs/dispersion.md.
#include "app/commands.h"
#include "io/format.h"
#include "physics/dispersion.h"
#include "physics/material.h"
#include "report/plot.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::app {

namespace {

using physics::Material;
using physics::ModeFamily;
using physics::ModePoint;

// A bad option: the message already names it.
struct UsageError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

struct DispersionArgs {
    std::string material, density, youngs, poisson, cl, ct, thickness, freq;
    std::string modes = "all", mindlin = "pi2/12", plot, plot_y = "phase";
    bool plot_log = false;
};

std::vector<std::string> split(const std::string &s, char sep)
{
    std::vector<std::string> out;
    std::string cur;
    for (char ch : s) {
        if (ch == sep) {
            out.push_back(cur);
            cur.clear();
        } else if (!std::isspace(static_cast<unsigned char>(ch))) {
            cur += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
        }
    }
    out.push_back(cur);
    return out;
}

bool parse_double(const std::string &s, double &v)
{
    if (s.empty())
        return false;
    try {
        std::size_t used = 0;
        v = std::stod(s, &used);
        return used == s.size() && std::isfinite(v);
    } catch (const std::exception &) {
        return false;
    }
}

double positive(const char *option, const std::string &text, const char *unit)
{
    double v = 0;
    if (!parse_double(text, v) || !(v > 0))
        throw UsageError(std::string(option) + ": expected a positive number (" + unit + "), got '" + text + "'");
    return v;
}

// "START:STOP:STEP" (inclusive) or "F1,F2,...", all in Hz.
std::vector<double> parse_frequencies(const std::string &text)
{
    const auto bad = [&](const std::string &why) {
        return UsageError("--freq: " + why +
                          " (expected START:STOP:STEP, START:STOP:xRATIO or F1,F2,... in Hz, positive), got '" + text +
                          "'");
    };
    std::vector<double> f;
    if (text.find(':') != std::string::npos) {
        const std::vector<std::string> p = split(text, ':');
        double start = 0, stop = 0, step = 0;
        // STEP may be "xR": a geometric range with ratio R.
        const bool geometric = p.size() == 3 && !p[2].empty() && p[2][0] == 'x';
        if (p.size() != 3 || !parse_double(p[0], start) || !parse_double(p[1], stop) ||
            !parse_double(geometric ? p[2].substr(1) : p[2], step))
            throw bad("not a range");
        if (!(start > 0) || stop < start || (geometric ? !(step > 1) : !(step > 0)))
            throw bad(geometric ? "need 0 < START <= STOP and ratio > 1" : "need 0 < START <= STOP and STEP > 0");
        const double n = geometric ? std::floor(std::log(stop / start) / std::log(step) + 1e-9) + 1
                                   : std::floor((stop - start) / step * (1 + 1e-12) + 1e-9) + 1;
        if (n > 1e6)
            throw bad("more than 1e6 frequencies");
        for (int i = 0; i < static_cast<int>(n); ++i)
            f.push_back(geometric ? start * std::pow(step, i) : start + i * step);
    } else {
        for (const std::string &tok : split(text, ',')) {
            double v = 0;
            if (!parse_double(tok, v) || !(v > 0))
                throw bad("'" + tok + "' is not a positive frequency");
            f.push_back(v);
        }
    }
    return f;
}

std::vector<Material> resolve_materials(const DispersionArgs &a)
{
    const bool elastic = !a.youngs.empty() || !a.poisson.empty();
    const bool speeds = !a.cl.empty() || !a.ct.empty();
    const bool custom = elastic || speeds || !a.density.empty();
    if (!a.material.empty() && custom)
        throw UsageError("--material: cannot be combined with --density/--youngs/--poisson/--cl/--ct");
    if (!a.material.empty()) {
        std::vector<Material> out;
        for (const std::string &name : split(a.material, ',')) {
            std::optional<Material> m = physics::find_material(name);
            if (!m)
                throw UsageError("--material: unknown material '" + name +
                                 "' (known: " + physics::known_material_names() + ")");
            out.push_back(*m);
        }
        return out;
    }
    if (!custom)
        throw UsageError(
            "--material: give a material name, or --density with --youngs --poisson, or --density with --cl --ct");
    if (elastic && speeds)
        throw UsageError("--youngs/--poisson: cannot be combined with --cl/--ct (give one pair)");
    if (a.density.empty())
        throw UsageError("--density: required for a custom material");
    const double rho = positive("--density", a.density, "kg/m^3");
    try {
        if (elastic) {
            if (a.youngs.empty() || a.poisson.empty())
                throw UsageError(a.youngs.empty() ? "--youngs: required with --poisson"
                                                  : "--poisson: required with --youngs");
            double nu = 0;
            if (!parse_double(a.poisson, nu))
                throw UsageError("--poisson: expected a number in (-1, 0.5), got '" + a.poisson + "'");
            return {physics::material_from_elastic(rho, positive("--youngs", a.youngs, "Pa"), nu)};
        }
        if (a.cl.empty() || a.ct.empty())
            throw UsageError(a.cl.empty() ? "--cl: required with --ct" : "--ct: required with --cl");
        return {physics::material_from_speeds(rho, positive("--cl", a.cl, "m/s"), positive("--ct", a.ct, "m/s"))};
    } catch (const std::invalid_argument &e) {
        throw UsageError(std::string(elastic ? "--youngs/--poisson" : "--cl/--ct") + ": " + e.what());
    }
}

// Which modes to print: names (a0, s1, sh2), whole families (a, s, sh), all.
struct ModeFilter {
    bool all = false;
    bool family[3] = {false, false, false};
    std::vector<std::string> names;

    bool wants(ModeFamily f) const
    {
        if (all || family[static_cast<int>(f)])
            return true;
        const std::string prefix = f == ModeFamily::antisymmetric ? "a" : f == ModeFamily::symmetric ? "s" : "sh";
        return std::any_of(names.begin(), names.end(), [&](const std::string &n) {
            return n.rfind(prefix, 0) == 0 && n.size() > prefix.size() &&
                   std::isdigit(static_cast<unsigned char>(n[prefix.size()]));
        });
    }
    bool wants(const ModePoint &p) const
    {
        if (all || family[static_cast<int>(p.family)])
            return true;
        std::string n = p.name();
        std::transform(n.begin(), n.end(), n.begin(), [](unsigned char ch) { return std::tolower(ch); });
        return std::find(names.begin(), names.end(), n) != names.end();
    }
};

ModeFilter parse_modes(const std::string &text)
{
    ModeFilter f;
    for (const std::string &tok : split(text, ',')) {
        if (tok == "all")
            f.all = true;
        else if (tok == "a")
            f.family[static_cast<int>(ModeFamily::antisymmetric)] = true;
        else if (tok == "s")
            f.family[static_cast<int>(ModeFamily::symmetric)] = true;
        else if (tok == "sh")
            f.family[static_cast<int>(ModeFamily::shear_horizontal)] = true;
        else {
            const std::size_t digits = tok.rfind("sh", 0) == 0 ? 2 : 1;
            const bool ok = tok.size() > digits && (tok[0] == 'a' || tok[0] == 's') &&
                            std::all_of(tok.begin() + static_cast<long>(digits), tok.end(),
                                        [](unsigned char ch) { return std::isdigit(ch); }) &&
                            tok.size() - digits <= 3;
            if (!ok)
                throw UsageError("--modes: unknown mode '" + tok + "' (use a0, s0, sh0, a1, ..., a, s, sh or all)");
            f.names.push_back(tok);
        }
    }
    return f;
}

struct Row {
    std::size_t fi; // index into the frequency list
    std::string material;
    ModePoint p;
    double kirchhoff = NAN, mindlin = NAN; // A0 rows only
};

void run(const DispersionArgs &a)
{
    const std::vector<Material> materials = resolve_materials(a);
    const double d = positive("--thickness", a.thickness, "m");
    if (d > 10)
        throw UsageError("--thickness: " + a.thickness + " m is not a plate thickness (the unit is metres)");
    const std::vector<double> freqs = parse_frequencies(a.freq);
    const ModeFilter filter = parse_modes(a.modes);
    physics::MindlinShear shear;
    if (a.mindlin == "pi2/12")
        shear = physics::MindlinShear::pi2_over_12;
    else if (a.mindlin == "rayleigh")
        shear = physics::MindlinShear::rayleigh;
    else
        throw UsageError("--mindlin-shear: expected 'pi2/12' or 'rayleigh', got '" + a.mindlin + "'");
    if (a.plot_y != "phase" && a.plot_y != "group" && a.plot_y != "wavelength")
        throw UsageError("--plot-y: expected phase, group or wavelength, got '" + a.plot_y + "'");

    std::vector<Row> rows;
    for (const Material &m : materials)
        for (std::size_t fi = 0; fi < freqs.size(); ++fi)
            for (ModeFamily fam : {ModeFamily::antisymmetric, ModeFamily::symmetric, ModeFamily::shear_horizontal}) {
                if (!filter.wants(fam))
                    continue;
                const double f = freqs[fi];
                for (const ModePoint &p : physics::solve_family(m, d, f, fam)) {
                    if (!filter.wants(p))
                        continue;
                    Row r{fi, m.name, p};
                    if (fam == ModeFamily::antisymmetric && p.order == 0) {
                        r.kirchhoff = physics::kirchhoff_phase_velocity(m, d, f);
                        r.mindlin = physics::mindlin_phase_velocity(m, d, f, shear);
                    }
                    rows.push_back(r);
                }
            }

    if (!a.plot.empty()) {
        report::Plot plot;
        const bool several = materials.size() > 1;
        char thick[64];
        std::snprintf(thick, sizeof thick, "d = %g mm", d * 1e3);
        plot.title = "Lamb-wave dispersion, " + std::string(thick) + (several ? "" : ", " + materials[0].name);
        plot.x = {"frequency (Hz)", a.plot_log ? report::AxisScale::log : report::AxisScale::linear};
        const char *ylabel = a.plot_y == "phase"   ? "phase velocity (m/s)"
                             : a.plot_y == "group" ? "group velocity (m/s)"
                                                   : "wavelength (m)";
        plot.y = {ylabel, a.plot_log ? report::AxisScale::log : report::AxisScale::linear};
        plot.legend = a.plot_y == "wavelength" ? report::LegendPosition::top_right : report::LegendPosition::top_left;
        auto value = [&](const ModePoint &p) {
            return a.plot_y == "phase"   ? p.phase_velocity_m_s
                   : a.plot_y == "group" ? p.group_velocity_m_s
                                         : p.wavelength_m;
        };
        // One series per (material, mode name), NaN where the mode does not
        // propagate; Kirchhoff (dashed) and Mindlin (dotted) beside each A0.
        std::map<std::pair<std::string, std::string>, std::size_t> index;
        double fundamental_max = 0, cl_max = 0;
        for (const Material &m : materials)
            cl_max = std::max(cl_max, m.cl_m_s());
        auto series_for = [&](const std::string &mat, const std::string &key, const std::string &label,
                              report::LineStyle style, std::optional<report::Color> color) -> report::Series & {
            auto [it, added] = index.try_emplace({mat, key}, plot.series.size());
            if (added) {
                report::Series s;
                s.label = several ? mat + " " + label : label;
                s.style = style;
                s.color = color;
                s.x = freqs;
                s.y.assign(freqs.size(), NAN);
                plot.series.push_back(std::move(s));
            }
            return plot.series[it->second];
        };
        std::size_t colour = 0;
        std::map<std::pair<std::string, std::string>, report::Color> colours;
        for (const Row &r : rows) {
            const std::size_t at = r.fi;
            auto [cit, fresh] = colours.try_emplace({r.material, r.p.name()}, report::palette(colour));
            if (fresh)
                ++colour;
            series_for(r.material, r.p.name(), r.p.name(), report::LineStyle::solid, cit->second).y[at] = value(r.p);
            if (r.p.order == 0)
                fundamental_max = std::max(fundamental_max, value(r.p));
            if (!std::isnan(r.kirchhoff)) {
                const Material &m = *std::find_if(materials.begin(), materials.end(),
                                                  [&](const Material &x) { return x.name == r.material; });
                const double k = a.plot_y == "phase"   ? r.kirchhoff
                                 : a.plot_y == "group" ? physics::kirchhoff_group_velocity(m, d, r.p.f_hz)
                                                       : r.kirchhoff / r.p.f_hz;
                const double mi = a.plot_y == "phase"   ? r.mindlin
                                  : a.plot_y == "group" ? physics::mindlin_group_velocity(m, d, r.p.f_hz, shear)
                                                        : r.mindlin / r.p.f_hz;
                series_for(r.material, "~kirchhoff", "A0 Kirchhoff", report::LineStyle::dashed, cit->second).y[at] = k;
                series_for(r.material, "~mindlin", "A0 Mindlin", report::LineStyle::dotted, cit->second).y[at] = mi;
            }
        }
        // Higher modes start at infinite phase speed and wavelength: cap the axis.
        const bool higher = std::any_of(rows.begin(), rows.end(), [](const Row &r) { return r.p.order > 0; });
        if (higher && a.plot_y == "phase")
            plot.y.max = 2 * cl_max;
        if (higher && a.plot_y == "wavelength")
            plot.y.max = fundamental_max;
        if (!a.plot_log && a.plot_y != "wavelength")
            plot.y.min = 0.0;
        try {
            report::write_plot(plot, a.plot);
        } catch (const std::invalid_argument &e) {
            throw UsageError(std::string("--plot: ") + e.what());
        }
    }

    std::string csv = "f_hz,mode,phase_velocity_m_s,group_velocity_m_s,wavelength_m,wavenumber_rad_m,"
                      "kirchhoff_phase_velocity_m_s,kirchhoff_rel_error,mindlin_phase_velocity_m_s,mindlin_rel_error,"
                      "material\n";
    for (const Row &r : rows) {
        const ModePoint &p = r.p;
        csv += io::fmt("%.9g,", p.f_hz) + p.name() +
               io::fmt(",%.9g,%.9g,%.9g,%.9g,", p.phase_velocity_m_s, p.group_velocity_m_s, p.wavelength_m,
                       p.wavenumber_rad_m);
        if (!std::isnan(r.kirchhoff))
            csv += io::fmt("%.9g,%.9g,%.9g,%.9g,", r.kirchhoff, r.kirchhoff / p.phase_velocity_m_s - 1, r.mindlin,
                           r.mindlin / p.phase_velocity_m_s - 1);
        else
            csv += ",,,,";
        csv += r.material + '\n';
    }
    std::fwrite(csv.data(), 1, csv.size(), stdout);
    std::fflush(stdout);
}

} // namespace

void register_dispersion(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<DispersionArgs>();
    CLI::App *cmd = app.add_subcommand(
        "dispersion",
        "Lamb (A_n, S_n) and SH_n plate modes: phase/group velocity and wavelength as CSV, optional plot");
    cmd->add_option("--material", a->material,
                    "Built-in material(s), comma separated: " + physics::known_material_names());
    cmd->add_option("--density", a->density, "Custom material: density (kg/m^3)");
    cmd->add_option("--youngs", a->youngs, "Custom material: Young's modulus (Pa), with --poisson");
    cmd->add_option("--poisson", a->poisson, "Custom material: Poisson's ratio, with --youngs");
    cmd->add_option("--cl", a->cl,
                    "Custom material: longitudinal speed (m/s), with --ct; E and nu are derived from the pair");
    cmd->add_option("--ct", a->ct, "Custom material: shear speed (m/s), with --cl");
    cmd->add_option("--thickness", a->thickness, "Plate thickness (m)")->required();
    cmd->add_option("--freq", a->freq,
                    "Frequencies (Hz): START:STOP:STEP (inclusive), START:STOP:xRATIO (geometric) or F1,F2,...")
        ->required();
    cmd->add_option("--modes", a->modes, "Modes: a0,s0,sh0,a1,... or families a,s,sh, or all (default)");
    cmd->add_option("--mindlin-shear", a->mindlin, "Mindlin shear factor: pi2/12 (default) or rayleigh");
    cmd->add_option("--plot", a->plot, "Also draw the dispersion diagram to FILE.svg or FILE.png");
    cmd->add_option("--plot-y", a->plot_y, "Plotted quantity: phase (default), group or wavelength");
    cmd->add_flag("--plot-log", a->plot_log, "Log-log axes");
    cmd->callback([a, &exit_code] {
        try {
            run(*a);
            exit_code = 0;
        } catch (const UsageError &e) {
            std::fprintf(stderr, "calibgen dispersion: %s\n", e.what());
            exit_code = 2;
        } catch (const std::exception &e) {
            std::fprintf(stderr, "calibgen dispersion: %s\n", e.what());
            exit_code = 1;
        }
    });
}

} // namespace calib::app
