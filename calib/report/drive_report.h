// The drive design in the calibration report: which method made the signals
// (time reversal or the inverse filter, its regularisation and lead time) and
// what each focus's drive costs (pipeline/verification/drive_figures.h), in metrics.json
// and index.html.
#pragma once
#include "pipeline/verification/drive_figures.h"
#include "report/calibration_report.h"

#include <toml++/toml.h>

#include <string>
#include <vector>

namespace calib::report {

// Per focus, when the context holds the stored signals; empty otherwise.
std::vector<pipeline::DriveFigures> drive_figures_of(const ReportContext &c);
// "time_reversal" or "inverse_filter".
const char *method_name(const pipeline::CalibrationInput &in);
// Root keys (method, lead_time_target_s, regularization) and per-focus keys
// (drive_energy_n2s, drive_out_of_band_fraction, peak_per_root_energy).
void add_drive_metrics(toml::table &root, toml::array &foci, const ReportContext &c);
// A section of index.html.
std::string drive_design_html(const ReportContext &c);

} // namespace calib::report
