#include "report/bench_report.h"

#include "io/atomic_file.h"
#include "io/format.h"
#include "report/canvas.h"
#include "report/plot.h"

#include <toml++/toml.h>

#include <filesystem>
#include <sstream>

namespace calib::report {

using io::fmt;

void write_bench_report(const std::string &dir, const pipeline::BenchModel &model,
                        const pipeline::BenchMeasured &measured, const pipeline::BenchFitResult &r)
{
    std::filesystem::create_directories(dir);
    const pipeline::BenchSetup &setup = model.setup();
    const std::size_t N = model.samples();

    toml::array params;
    for (const pipeline::FitParameter &p : r.parameters)
        params.push_back(toml::table{{"name", p.name},
                                     {"scene", p.nominal},
                                     {"fitted", p.value},
                                     {"sigma", p.sigma},
                                     {"was_fitted", p.fitted},
                                     {"identifiable", p.identifiable},
                                     {"note", p.note}});
    toml::array pairs;
    for (const pipeline::PairFit &p : r.pairs)
        pairs.push_back(toml::table{{"sensor", int64_t(p.sensor + 1)},
                                    {"exciter", int64_t(p.exciter + 1)},
                                    {"residual_before_db", p.before_db},
                                    {"residual_after_db", p.after_db}});
    toml::array notes;
    for (const std::string &n : r.notes)
        notes.push_back(n);
    toml::table root{{"speed_ratio", r.fitted.speed_ratio},
                     {"loss_factor", r.fitted.loss_factor},
                     {"scanned_speed_ratio", r.scanned_speed_ratio},
                     {"residual_before_db", r.residual_before_db},
                     {"residual_after_db", r.residual_after_db},
                     {"band_hz", toml::array{setup.f_lo_hz, setup.f_hi_hz}},
                     {"window_s", setup.window_s},
                     {"iterations", int64_t(r.iterations)},
                     {"simulations", int64_t(r.simulations)},
                     {"seconds", r.seconds},
                     {"parameters", std::move(params)},
                     {"pairs", std::move(pairs)},
                     {"notes", std::move(notes)}};
    std::ostringstream js;
    js << toml::json_formatter{root} << "\n";
    io::write_file_atomic(dir + "/fit.json", js.str());

    std::ostringstream h;
    h << "<!doctype html><html><head><meta charset=\"utf-8\"><title>bench fit</title><style>"
         "body{font-family:sans-serif;max-width:1100px;margin:auto}td,th{padding:2px 8px;text-align:right}"
         "td:first-child,th:first-child{text-align:left}.bad{color:#b00}</style></head><body>";
    h << "<h1>Bench fit</h1><p>Band " << fmt("%.0f-%.0f Hz", setup.f_lo_hz, setup.f_hi_hz) << ", window "
      << fmt("%.0f ms", setup.window_s * 1e3)
      << ". Residual (energy of simulated minus measured, over measured): " << fmt("%.1f dB", r.residual_before_db)
      << " with the scene's values, " << fmt("%.1f dB", r.residual_after_db) << " fitted. " << r.iterations
      << " solver iterations, " << r.simulations << " simulations, " << fmt("%.1f s", r.seconds) << ".</p>";
    h << "<h2>Parameters</h2><table><tr><th>parameter</th><th>scene</th><th>fitted</th><th>&plusmn;1 &sigma;</th>"
         "<th></th></tr>";
    for (const pipeline::FitParameter &p : r.parameters)
        h << "<tr><td>" << canvas::xml_escape(p.name) << "</td><td>" << fmt("%.5g", p.nominal) << "</td><td>"
          << fmt("%.5g", p.value) << "</td><td>" << (p.fitted ? fmt("%.2g", p.sigma) : "") << "</td><td"
          << (p.identifiable ? ">" : " class=\"bad\">not identifiable; ") << canvas::xml_escape(p.note) << "</td></tr>";
    h << "</table>";
    for (const std::string &n : r.notes)
        h << "<p>" << canvas::xml_escape(n) << "</p>";
    h << "<h2>Responses</h2><p>Measured (black), simulated with the scene's values (grey, dashed) and with the "
         "fitted ones (colour); each sensor in its own quantity, filtered to the band.</p>";
    std::vector<double> t(N), m0(N), m1(N);
    for (std::size_t i = 0; i < N; i++)
        t[i] = double(i) / model.rate_hz() * 1e3;
    pipeline::BenchParams start = r.start;
    start.sensor_gains = r.fitted.sensor_gains;
    for (const pipeline::PairFit &p : r.pairs) {
        model.response(start, p.sensor, p.exciter, m0.data());
        model.response(r.fitted, p.sensor, p.exciter, m1.data());
        Plot pl;
        pl.title = "sensor " + std::to_string(p.sensor + 1) + ", exciter " + std::to_string(p.exciter + 1) + ": " +
                   fmt("%.1f", p.before_db) + " -> " + fmt("%.1f dB", p.after_db);
        pl.x = {"time (ms)"};
        pl.y = {pipeline::sensor_quantity_name(setup.sensors[p.sensor].quantity)};
        pl.width_px = 520, pl.height_px = 260;
        pl.legend = LegendPosition::hidden;
        const std::vector<double> &y = measured.responses[p.sensor][p.exciter];
        pl.add({"measured", t, std::vector<double>(y.begin(), y.begin() + long(N)), LineStyle::solid, Color{0, 0, 0}});
        pl.add({"scene", t, m0, LineStyle::dashed, Color{150, 150, 150}});
        pl.add({"fitted", t, m1, LineStyle::solid, palette(0)});
        h << render_svg(pl);
    }
    h << "</body></html>\n";
    io::write_file_atomic(dir + "/index.html", h.str());
}

} // namespace calib::report
