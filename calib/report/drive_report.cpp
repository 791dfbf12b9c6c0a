#include "report/drive_report.h"

#include "io/format.h"
#include "pipeline/data/lead_time.h"

#include <sstream>

namespace calib::report {

using io::fmt;

const char *method_name(const pipeline::CalibrationInput &in)
{
    return in.calibration.method == pipeline::DriveMethod::inverse_filter ? "inverse_filter" : "time_reversal";
}

std::vector<pipeline::DriveFigures> drive_figures_of(const ReportContext &c)
{
    std::vector<pipeline::DriveFigures> out;
    if (!c.signals || c.mode != "table" || c.signals->size() != c.verification->foci.size())
        return out;
    const unsigned C = static_cast<unsigned>(c.exciters.size());
    for (std::size_t f = 0; f < c.signals->size(); f++)
        out.push_back(
            pipeline::drive_figures(*c.input, (*c.signals)[f], C, c.signal_rate_hz, c.verification->foci[f].peak_m));
    return out;
}

void add_drive_metrics(toml::table &root, toml::array &foci, const ReportContext &c)
{
    const pipeline::CalibrationInput &in = *c.input;
    root.insert("method", std::string(method_name(in)));
    root.insert("lead_time_target_s", pipeline::target_lead_time_s(in));
    if (in.calibration.method == pipeline::DriveMethod::inverse_filter) {
        root.insert("regularization", in.calibration.regularization);
        root.insert("active_damping_s", in.calibration.active_damping_s);
    }
    const std::vector<pipeline::DriveFigures> d = drive_figures_of(c);
    for (std::size_t f = 0; f < d.size() && f < foci.size(); f++)
        if (toml::table *t = foci[f].as_table()) {
            t->insert("drive_energy_n2s", d[f].energy_n2s);
            t->insert("drive_out_of_band_fraction", d[f].out_of_band_fraction);
            t->insert("peak_per_root_energy", d[f].peak_per_root_energy);
        }
}

std::string drive_design_html(const ReportContext &c)
{
    const pipeline::CalibrationInput &in = *c.input;
    const bool inverse = in.calibration.method == pipeline::DriveMethod::inverse_filter;
    std::ostringstream h;
    h << "<h2>Drive design</h2><p>Method: <b>" << (inverse ? "inverse filter" : "time reversal") << "</b>, "
      << "focal peak aimed at " << fmt("%.1f", pipeline::target_lead_time_s(in) * 1e3) << " ms after playback starts";
    if (inverse)
        h << ", regularization " << fmt("%g", in.calibration.regularization)
          << " (Tikhonov weight relative to the largest eigenvalue of H<sup>T</sup>H; control points: the active "
             "area beyond lambda/2 from the focus, at all times)";
    if (inverse && in.calibration.active_damping_s > 0)
        h << "; the drive continues " << fmt("%.1f", in.calibration.active_damping_s * 1e3)
          << " ms after the focal instant, holding the area at zero (active damping)";
    h << ".</p>";
    const std::vector<pipeline::DriveFigures> d = drive_figures_of(c);
    if (d.empty())
        return h.str();
    h << "<table><tr><th>focus</th><th>drive energy (N<sup>2</sup> s)</th><th>energy above the pulse band (%)</th>"
         "<th>focal peak per root energy (um / (N s<sup>1/2</sup>))</th><th>sound on axis at 0.5 m, L<sub>AE</sub> "
         "(dB(A))</th></tr>";
    for (std::size_t f = 0; f < d.size(); f++) {
        const pipeline::FocusMetrics &m = c.verification->foci[f];
        h << "<tr><td>" << m.id << "</td><td>" << fmt("%.3g", d[f].energy_n2s) << "</td><td>"
          << fmt("%.2f", 100 * d[f].out_of_band_fraction) << "</td><td>" << fmt("%.3g", d[f].peak_per_root_energy * 1e6)
          << "</td><td>" << (m.sound ? fmt("%.1f", m.sound_exposure_dba) : std::string("-")) << "</td></tr>";
    }
    h << "</table>";
    return h.str();
}

} // namespace calib::report
