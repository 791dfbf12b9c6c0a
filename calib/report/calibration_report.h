// What `calibgen calibrate` and `calibgen verify` leave in the report
// directory: metrics.json (machine-readable, keys listed in docs/report.md;
// scripts and docs/REPRODUCTION.md read them) and
// index.html (self-contained: inline SVG and PNG data URIs, opens anywhere).
#pragma once
#include "engine/modes.h"
#include "pipeline/calibrate.h"

#include <string>

namespace calib::report {

struct ReportContext {
    const pipeline::CalibrationInput *input = nullptr;
    const pipeline::CalibrationResult *result = nullptr; // null for `verify` (no placement, no signals)
    const pipeline::Verification *verification = nullptr;
    std::vector<pipeline::Point> exciters;
    std::string table_path;
    std::string scene_path;
    std::string mode = "table";                // "table" or "drive" (verify --drive)
    const engine::PlateModes *modes = nullptr; // `calibrate --modes N`: the plate's lowest modes
    // The stored signals per focus ([n][c] int16) and their rate: the drive
    // figures (report/drive_report.h); null: none reported.
    const std::vector<std::vector<int16_t>> *signals = nullptr;
    double signal_rate_hz = 0;
    double peak_rss_mb = 0;
    double total_s = 0;
};

// metrics.json into dir (created if missing), atomically.
void write_metrics_json(const std::string &dir, const ReportContext &ctx);
// index.html into dir, atomically.
void write_html_report(const std::string &dir, const ReportContext &ctx);

} // namespace calib::report
