#include "study/latency.h"

#include "io/format.h"
#include "io/read_file.h"
#include "model/error_model.h"
#include "physics/dispersion.h"
#include "pipeline/calibrate.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/placement_verdict.h"
#include "pipeline/verification/drive_figures.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/verification/multitouch.h"
#include "pipeline/verification/radiation.h"
#include "pipeline/plan.h"
#include "pipeline/verification/verification.h"
#include "pipeline/transfer/transfer.h"
#include "scene/calibration_input.h"

#include <algorithm>
#include <numbers>
#include <chrono>
#include <cmath>
#include <stdexcept>

namespace calib::study {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// One case on the shared H: the drives, their level, the verification.
void run_case(const pipeline::CalibrationInput &base, const pipeline::TransferMatrix &H,
              const std::vector<pipeline::Point> &exciters, const LatencyOptions &o, LatencyRow &row)
{
    pipeline::CalibrationInput in = base;
    in.calibration.method = row.method;
    in.calibration.regularization = row.regularization;
    if (row.scene_default)
        in.calibration.lead_time_s.reset();
    else
        in.calibration.lead_time_s = row.lead_target_s;
    row.lead_target_s = pipeline::target_lead_time_s(in);
    pipeline::check_lead_time(in, exciters);
    pipeline::CalibrationResult r;
    r.exciters = exciters;
    pipeline::signals_and_verification(in, H, {}, r);
    row.worst_whole_area_db = row.worst_other_foci_db = INFINITY;
    row.min_peak_m = row.margin_m = row.min_peak_per_root_energy = INFINITY;
    row.all_cross = row.all_alone = true;
    for (std::size_t f = 0; f < r.verification.foci.size(); f++) {
        const pipeline::FocusMetrics &m = r.verification.foci[f];
        row.lead_measured_s = std::max(row.lead_measured_s, m.lead_time_s);
        row.worst_whole_area_db = std::min(row.worst_whole_area_db, m.whole_area_contrast_db);
        row.worst_other_foci_db = std::min(row.worst_other_foci_db, m.other_foci_contrast_db);
        row.min_peak_m = std::min(row.min_peak_m, m.peak_m);
        row.margin_m = std::min(row.margin_m, in.calibration.threshold_m - m.max_whole_area_m);
        row.all_cross &= m.crosses_threshold;
        row.all_alone &= m.passes(); // the verdict (data/verdict.h)
        const pipeline::DriveFigures d = pipeline::drive_figures(in, r.signals[f].samples, unsigned(exciters.size()),
                                                                 in.calibration.output_rate_hz, m.peak_m);
        row.min_peak_per_root_energy = std::min(row.min_peak_per_root_energy, d.peak_per_root_energy);
        row.max_energy_n2s = std::max(row.max_energy_n2s, d.energy_n2s);
        row.max_out_of_band = std::max(row.max_out_of_band, d.out_of_band_fraction);
    }
    std::vector<std::vector<int16_t>> stored;
    for (const pipeline::DriveSignals &d : r.signals)
        stored.push_back(d.samples);
    row.max_sound_dba = -INFINITY;
    for (const pipeline::RadiatedSound &snd : pipeline::radiated_sounds(in, H, stored, in.calibration.output_rate_hz))
        row.max_sound_dba = std::max(row.max_sound_dba, snd.exposure_level_dba);
    if (!o.multitouch)
        return;
    pipeline::MultiTouchOptions mo;
    mo.triples = o.triples;
    mo.joint = o.joint && row.method == pipeline::DriveMethod::inverse_filter;
    pipeline::MultiTouchReport mt = pipeline::verify_multitouch(in, H, stored, in.calibration.output_rate_hz, mo);
    const pipeline::MultiTouchCase *worst_pair = nullptr, *worst_triple = nullptr;
    for (const pipeline::MultiTouchCase &c : mt.cases) {
        const bool pair = c.foci.size() == 2;
        (pair ? row.pairs : row.triples)++;
        (pair ? row.pairs_failing : row.triples_failing) += !c.superposed.ok;
        const pipeline::MultiTouchCase *&w = pair ? worst_pair : worst_triple;
        if (!w || c.superposed.margin_m < w->superposed.margin_m)
            w = &c;
    }
    if (worst_pair) {
        for (int i = 0; i < 2; i++)
            row.worst_pair[i] = in.foci.points[worst_pair->foci[std::size_t(i)]].id;
        row.worst_pair_margin_m = worst_pair->superposed.margin_m;
    }
    if (worst_triple) {
        for (int i = 0; i < 3; i++)
            row.worst_triple[i] = in.foci.points[worst_triple->foci[std::size_t(i)]].id;
        row.worst_triple_margin_m = worst_triple->superposed.margin_m;
    }
    row.sets = std::move(mt.cases);
}

// ", triples failing a/b" and the joint designs' counts, when there are any.
std::string sets_line(const LatencyRow &row)
{
    std::string s;
    if (row.triples)
        s += ", triples failing " + std::to_string(row.triples_failing) + "/" + std::to_string(row.triples);
    std::size_t pairs = 0, triples = 0, joint = 0;
    for (const pipeline::MultiTouchCase &c : row.sets)
        if (c.has_joint) {
            joint++;
            (c.foci.size() == 2 ? pairs : triples) += !c.joint.ok;
        }
    if (joint)
        s += "; joint designs failing: " + std::to_string(pairs) + " pairs" +
             (row.triples ? ", " + std::to_string(triples) + " triples" : std::string());
    return s;
}

} // namespace

LatencyResult run_latency_study(const std::string &path, const LatencyOptions &o, const LatencyProgress &progress)
{
    auto say = [&](const std::string &s) {
        if (progress)
            progress(s);
    };
    if (o.lead_times_s.empty())
        throw std::invalid_argument("latency study: no lead times to sweep");
    const std::optional<std::string> bytes = io::read_file(path);
    if (!bytes)
        throw std::runtime_error(path + ": cannot open scene file");
    scene::Scene s = scene::parse_scene(*bytes, path);
    if (!s.calibration_sections())
        throw std::runtime_error(path + ": not a calibration scene");
    model::apply_accuracy_target(s);
    pipeline::CalibrationInput in = scene::calibration_input(s, scene::build_plate(s), *bytes);
    if (!pipeline::transfer_holds(in))
        throw std::runtime_error(path + ": the latency study needs the transfer matrix ([effects.finger] is on)");
    LatencyResult res;
    res.scene_file = path;
    res.scene_name = in.scene_name;
    res.threshold_m = in.calibration.threshold_m;
    for (const auto &f : in.foci.points)
        res.focus_ids.push_back(f.id);
    try {
        pipeline::check_feasible(in);
    } catch (const std::invalid_argument &e) {
        throw std::runtime_error(path + ": " + e.what());
    }

    // The scene's placement, once.
    auto t0 = Clock::now();
    say("placement (the scene's search)");
    res.exciters = pipeline::placed_exciters(in);
    res.placement_s = since(t0);
    res.crossing_s = pipeline::crossing_time_s(in, res.exciters);
    const double kappa = in.plate->kappa();
    res.ceiling = pipeline::ideal_focus_ceiling(
        in.pulse, [&](double f) { return 2 * std::numbers::pi / physics::kirchhoff_wavelength_m(kappa, f); },
        physics::kirchhoff_wavelength_m(kappa, in.pulse.centre_hz) / 2);

    // H long enough for the longest lead time and for the scene's own window.
    t0 = Clock::now();
    pipeline::CalibrationInput longest = in;
    const double max_lead = *std::max_element(o.lead_times_s.begin(), o.lead_times_s.end());
    longest.calibration.lead_time_s = max_lead;
    if (pipeline::kept_window_s(longest) < pipeline::kept_window_s(in))
        longest.calibration.lead_time_s.reset();
    say("transfer matrix");
    const pipeline::TransferMatrix H = pipeline::transfer_for(longest, res.exciters);
    res.transfer_s = since(t0);

    const std::vector<double> regs =
        o.regularizations.empty() ? std::vector<double>{in.calibration.regularization} : o.regularizations;
    std::vector<LatencyRow> cases;
    auto add = [&](pipeline::DriveMethod m, bool dflt, double lead) {
        LatencyRow row;
        row.method = m;
        row.scene_default = dflt;
        row.lead_target_s = lead;
        if (m == pipeline::DriveMethod::time_reversal) {
            cases.push_back(row);
            return;
        }
        for (double eps : regs) {
            row.regularization = eps;
            cases.push_back(row);
        }
    };
    add(pipeline::DriveMethod::time_reversal, true, 0);
    add(pipeline::DriveMethod::inverse_filter, true, 0);
    for (double lead : o.lead_times_s) {
        add(pipeline::DriveMethod::time_reversal, false, lead);
        add(pipeline::DriveMethod::inverse_filter, false, lead);
    }
    for (LatencyRow &row : cases) {
        t0 = Clock::now();
        try {
            run_case(in, H, res.exciters, o, row);
        } catch (const std::exception &e) {
            row.error = e.what();
        }
        row.seconds = since(t0);
        const bool tr = row.method == pipeline::DriveMethod::time_reversal;
        say(std::string(tr ? "time reversal " : "inverse filter") +
            (tr ? "" : " eps " + io::fmt("%g", row.regularization)) + " at " +
            io::fmt("%.1f ms", row.lead_target_s * 1e3) + (row.scene_default ? " (scene)" : "") + ": " +
            (row.error.empty() ? "worst whole-area " + io::fmt("%.1f dB", row.worst_whole_area_db) + ", margin " +
                                     io::fmt("%.2f um", row.margin_m * 1e6) + ", lead " +
                                     io::fmt("%.1f ms", row.lead_measured_s * 1e3) + ", pairs failing " +
                                     std::to_string(row.pairs_failing) + "/" + std::to_string(row.pairs) +
                                     sets_line(row) + ", " + io::fmt("%.1f s", row.seconds)
                               : "failed: " + row.error));
        res.rows.push_back(row);
    }
    return res;
}

} // namespace calib::study
