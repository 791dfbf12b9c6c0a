// `calibgen calibrate SCENE -o TABLE --report DIR` and
// `calibgen verify SCENE TABLE --report DIR [--drive FILE.wav --expect T:ID,...]`.
#include "app/commands.h"
#include "app/progress.h"
#include "report/effects_report.h"
#include "engine/modes.h"
#include "model/cost_model.h"
#include "model/error_model.h"
#include "model/resources.h"
#include "physics/dispersion.h"
#include "pipeline/calibrate.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/plan.h"
#include "pipeline/table_writer.h"
#include "pipeline/verification/verification.h"
#include "report/calibration_report.h"
#include "report/tolerance_report.h"
#include "scene/calibration_input.h"
#include "io/format.h"
#include "io/read_file.h"

#include <haptic_table.h>
#include <sndfile.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>
#include <optional>
#include <sstream>
#include <stdexcept>

namespace calib::app {

namespace {

using Clock = std::chrono::steady_clock;

using io::fmt;

// What calibrate and verify (and the dry run) need before anything runs: the
// scene after its accuracy target, as the pipeline's input, checked.
struct Prepared {
    scene::Scene scene;
    std::optional<model::Choice> choice;
    pipeline::CalibrationInput input;
};

struct LimitArgs;
Prepared prepare(const std::string &path, const LimitArgs &l, bool verification_only);

struct LimitArgs {
    std::optional<double> max_memory_mb, max_seconds;
    model::Limits limits() const { return model::machine_limits(max_memory_mb, max_seconds); }
};

Prepared prepare(const std::string &path, const LimitArgs &l, bool verification_only)
{
    const std::optional<std::string> bytes = io::read_file(path);
    if (!bytes)
        throw std::runtime_error(path + ": cannot open scene file");
    Prepared p{scene::parse_scene(*bytes, path), std::nullopt, {}};
    if (!p.scene.calibration_sections())
        throw std::runtime_error(path + ": not a calibration scene: it needs [active_area], [exciters], [foci], "
                                        "[pulse] and [calibration] sections");
    p.choice = model::apply_accuracy_target(p.scene); // calibration.accuracy picks the grid (docs/ACCURACY.md)
    if (!verification_only)                           // verify records the foci only: the full plan below prices it
        model::refuse_before_build(p.scene, l.limits(), true);
    p.input = scene::calibration_input(p.scene, scene::build_plate(p.scene), *bytes);
    try {
        pipeline::check_feasible(p.input);
    } catch (const std::invalid_argument &e) {
        throw std::runtime_error(path + ": " + e.what());
    }
    return p;
}

void add_limit_options(CLI::App *cmd, LimitArgs &l)
{
    cmd->add_option("--max-memory", l.max_memory_mb,
                    "Refuse (before simulating) a run predicted to need more than this many MB (default: physical "
                    "memory)");
    cmd->add_option("--max-seconds", l.max_seconds,
                    "Refuse (before simulating) a run predicted to take longer than this (default: no limit)");
}

// Plans, prices and refuses what does not fit, before any simulation.
pipeline::CalibrationInput input_from_scene(const std::string &path, const LimitArgs &l, bool verification_only)
{
    Prepared p = prepare(path, l, verification_only);
    if (p.choice)
        std::fprintf(stderr, "accuracy target %g %%: %.2f points per wavelength (predicted error %+.3f %%)\n",
                     100 * *p.scene.calibration->accuracy, p.choice->points_per_wavelength,
                     100 * p.choice->predicted_error);
    try {
        model::refuse_unaffordable(p.input, l.limits(), path, verification_only);
    } catch (const std::invalid_argument &e) {
        throw std::runtime_error(path + ": " + e.what());
    }
    return std::move(p.input);
}

// `calibgen calibrate --dry-run`: the setting the scene gets (after its
// accuracy target, if any), the predicted phase error at f_max, run time and
// peak memory of the calibration, without running it; then the verdict.
int dry_run(const std::string &path, const LimitArgs &l)
{
    Prepared p = prepare(path, l, false);
    const pipeline::CalibrationInput &in = p.input;
    const scene::Scene &s = p.scene;
    pipeline::CalibrationPlan plan;
    try {
        plan = pipeline::plan(in);
    } catch (const std::invalid_argument &e) {
        throw std::runtime_error(path + ": " + e.what());
    }
    const model::Limits limits = l.limits();
    // Time the cost model only for grids whose fields fit (the timing runs them).
    const model::Prediction bare = model::predict(in, plan, nullptr);
    const model::CostModel cost = model::measure_cost(in, plan, bare.memory_mb <= limits.memory_mb ? 5e6 : 2e6);
    const model::Prediction pr = model::predict(in, plan, &cost);
    const double f_max = model::scene_f_max_hz(s);
    const engine::Grid &g = in.plate->grid();
    const double lambda = physics::kirchhoff_wavelength_m(in.plate->kappa(), f_max);
    std::ostringstream o;
    o << "scene " << s.name << " (dry run: nothing simulated)\n";
    if (p.choice)
        o << "  accuracy target   " << fmt("%g %%", 100 * *s.calibration->accuracy)
          << " phase-velocity error at f_max: cheapest grid " << fmt("%.2f", p.choice->points_per_wavelength)
          << " points per wavelength\n";
    else
        o << "  accuracy target   none (calibration.accuracy unset): the scene's [simulation] settings\n";
    o << "  setting           " << fmt("%.2f", s.simulation.points_per_wavelength) << " points per wavelength at "
      << fmt("%.0f Hz", f_max) << " (grid " << fmt("%.2f", lambda / g.h) << "), "
      << engine::precision_name(in.simulation.precision) << ", Courant " << fmt("%g", in.simulation.courant)
      << ", model " << (in.effects.thick_plate ? "mindlin" : "kirchhoff") << "\n";
    o << "  grid              " << g.nx << " x " << g.ny << " cells of " << fmt("%.2f mm", g.h * 1e3) << ", step "
      << fmt("%.3g us", plan.time_step_s * 1e6) << ", " << plan.window_steps << " steps per "
      << fmt("%g s", in.calibration.window_s) << " window\n";
    o << "  predicted error   "
      << fmt("%+.3f %%",
             100 * model::predicted_phase_error(s.plate.material, s.plate.thickness_m, f_max, g.h, plan.time_step_s))
      << " phase velocity at f_max vs exact A0\n";
    o << "  placement foci    " << plan.foci << " of " << in.foci.points.size() << " weighed by the search (cap "
      << plan.placement_focus_cap << ", every focus within " << fmt("%.0f mm", plan.subset_cover_m * 1e3)
      << " of one), " << plan.emitters.size() << " placement simulations"
      << (pr.verdict_probes > 0 ? " + up to " + std::to_string(std::lround(pr.verdict_probes)) +
                                      " ghost probes (the search by the verdict, docs/verdict.md)"
                                : std::string())
      << "\n";
    o << "  predicted time    " << fmt("%.1f s", pr.seconds) << " (" << plan.emitters.size() << " simulations x "
      << plan.sites.size() << " sites, " << cost.threads << " threads, "
      << fmt("%.3g ms", cost.seconds_per_step_simulate * 1e3) << " per step measured now)\n";
    if (pr.design_s > 0)
        o << "  of which designs  " << fmt("%.1f s", pr.design_s) << " (inverse filter: " << in.foci.points.size()
          << " foci, " << fmt("%.3g s", cost.design.per_focus_s) << " each on one core measured now"
          << (model::searched_by_verdict(in) ? ", at most every placement the verdict judges" : "") << "), "
          << fmt("%.0f MB", pr.design_mb) << "\n";
    o << "  predicted memory  " << fmt("%.0f MB", pr.memory_mb) << " peak resident (limit "
      << fmt("%.0f MB", limits.memory_mb) << ", " << limits.memory_source << ")\n";
    std::printf("%s", o.str().c_str());
    std::fflush(stdout);
    model::refuse_if_over(path, pr.memory_mb, pr.seconds, limits, model::calibration_cause(in, plan, pr));
    return 0;
}

void print_summary(const pipeline::Verification &v, const pipeline::CalibrationInput &in, bool table_mode)
{
    if (!table_mode) { // a device recording: which focus moved how much, and when (judged by --expect)
        // A dense grid: only the foci that crossed the threshold, one line each.
        const bool all = v.foci.size() <= 12;
        std::fprintf(stderr, "%-6s %9s %9s %10s %12s\n", "focus", "x_mm", "y_mm", "peak_um", "at_ms");
        size_t quiet = 0;
        for (const pipeline::FocusMetrics &m : v.foci) {
            if (!all && !m.crosses_threshold) {
                quiet++;
                continue;
            }
            std::fprintf(stderr, "%-6u %9.1f %9.1f %10.2f %12.1f\n", m.id, m.at.x_m * 1e3, m.at.y_m * 1e3,
                         m.peak_m * 1e6, m.lead_time_s * 1e3);
        }
        if (quiet > 0)
            std::fprintf(stderr, "(%zu of %zu foci stayed below the %.1f um threshold)\n", quiet, v.foci.size(),
                         in.calibration.threshold_m * 1e6);
        return;
    }
    // Up to a dozen foci, one line each; a dense grid as worst / median / best.
    // Either way the verdict (data/verdict.h FocusMetrics::passes) comes last,
    // and every focus that fails says why and where its ghost is. Beside it
    // the safe range (FocusMetrics::gain_range): the gains, in dB relative to
    // the stored level, at which it passes, as the table stores them.
    const double thr = in.calibration.threshold_m;
    const pipeline::VerdictSummary verdict = pipeline::summarize_verdict(v.foci);
    const bool per_focus = v.foci.size() <= 12;
    if (per_focus) {
        std::fprintf(stderr, "%-6s %9s %9s %10s %11s %9s %9s %9s %8s %17s %s\n", "focus", "x_mm", "y_mm", "peak_um",
                     "others_um", "contr_dB", "area_dB", "spot_mm", "lead_ms", "safe_range_dB", "verdict");
        for (const pipeline::FocusMetrics &m : v.foci)
            std::fprintf(stderr, "%-6u %9.1f %9.1f %10.2f %11.2f %9.1f %9s %9.1f %8.1f %17s %s\n", m.id, m.at.x_m * 1e3,
                         m.at.y_m * 1e3, m.peak_m * 1e6, m.max_other_foci_m * 1e6, m.other_foci_contrast_db,
                         m.whole_area ? fmt("%.1f", m.whole_area_contrast_db).c_str() : "-", m.spot_diameter_m * 1e3,
                         m.lead_time_s * 1e3, pipeline::safe_range_text(m.gain_range(thr)).c_str(),
                         m.passes() ? "pass" : ("FAIL: " + m.failure(thr)).c_str());
    } else {
        auto stat = [&](const char *name, const char *unit, double scale, auto get) {
            std::vector<double> x;
            for (const pipeline::FocusMetrics &m : v.foci)
                x.push_back(get(m) * scale);
            std::sort(x.begin(), x.end());
            std::fprintf(stderr, "%-34s %9.2f %9.2f %9.2f %s\n", name, x.front(), x[x.size() / 2], x.back(), unit);
        };
        std::fprintf(stderr, "%zu foci %-26s %9s %9s %9s\n", v.foci.size(), "", "min", "median", "max");
        stat("peak", "um", 1e6, [](const pipeline::FocusMetrics &m) { return m.peak_m; });
        stat("contrast over the other foci", "dB", 1,
             [](const pipeline::FocusMetrics &m) { return m.other_foci_contrast_db; });
        stat("whole-area contrast, all times", "dB", 1,
             [](const pipeline::FocusMetrics &m) { return m.whole_area_contrast_db; });
        stat("spot diameter", "mm", 1e3, [](const pipeline::FocusMetrics &m) { return m.spot_diameter_m; });
        stat("lead time", "ms", 1e3, [](const pipeline::FocusMetrics &m) { return m.lead_time_s; });
        stat("perceived offset", "mm", 1e3,
             [](const pipeline::FocusMetrics &m) { return m.perceived_offset_distance_m; });
        // The failing foci, worst first, up to a dozen lines.
        std::vector<const pipeline::FocusMetrics *> failing;
        for (const pipeline::FocusMetrics &m : v.foci)
            if (!m.passes())
                failing.push_back(&m);
        std::sort(failing.begin(), failing.end(),
                  [](const auto *a, const auto *b) { return a->whole_area_contrast_db < b->whole_area_contrast_db; });
        for (std::size_t i = 0; i < failing.size() && i < 12; i++)
            std::fprintf(stderr, "focus %u at (%.1f, %.1f) mm FAILS: %s; safe_range_dB %s\n", failing[i]->id,
                         failing[i]->at.x_m * 1e3, failing[i]->at.y_m * 1e3, failing[i]->failure(thr).c_str(),
                         pipeline::safe_range_text(failing[i]->gain_range(thr)).c_str());
        if (failing.size() > 12)
            std::fprintf(stderr, "... and %zu more failing foci (metrics.json lists each)\n", failing.size() - 12);
        const pipeline::FocusMetrics &w = v.foci[verdict.worst];
        std::fprintf(stderr, "worst focus %u at (%.1f, %.1f) mm: whole-area contrast %.1f dB, peak %.2f um\n", w.id,
                     w.at.x_m * 1e3, w.at.y_m * 1e3, w.whole_area_contrast_db, w.peak_m * 1e6);
    }
    std::fprintf(stderr, "(threshold %.1f um, lambda/2 = %.1f mm, exciter force at full scale %.3g N)\n", thr * 1e6,
                 v.foci.empty() ? 0.0 : v.foci[0].lambda_half_m * 1e3, in.exciters.force_full_scale_n);
    std::fprintf(stderr, "verdict (%s, all times): %zu of %zu foci pass%s\n",
                 v.foci.empty() ? "whole area" : v.foci[0].verdict_scope(), verdict.passing, verdict.total,
                 verdict.all_pass() ? "" : ": the table makes ghosts or misses the threshold (exit status 3)");
}

bool all_good(const pipeline::Verification &v) { return pipeline::summarize_verdict(v.foci).all_pass(); }

// `--modes N` is checked with the scene, before the calibration runs: a count
// the grid allows, and the eigensolver's memory within the machine's.
void check_modes_fit(const std::string &path, const engine::PlateOperator &plate, int count,
                     const model::Limits &limits)
{
    if (count < 1 || std::size_t(count) >= plate.unknown_count())
        throw std::runtime_error("--modes " + std::to_string(count) + ": must be from 1 to " +
                                 std::to_string(plate.unknown_count() - 1) + " (the nodes free to move on " + path +
                                 ")");
    const double mb = 1024.0 * 1024.0;
    const double predicted_mb = model::current_rss_mb() + engine::lowest_modes_bytes(plate.unknown_count(), count) / mb;
    if (!(predicted_mb <= limits.memory_mb))
        throw std::runtime_error(path + ": --modes " + std::to_string(count) +
                                 " refused: the eigensolver is predicted to need " + fmt("%.0f MB", predicted_mb) +
                                 ", over this machine's " + fmt("%.0f MB", limits.memory_mb) + " (" +
                                 limits.memory_source + ")");
}

struct CalibrateArgs {
    std::string scene, table, report;
    int modes = 0; // the plate's lowest modes in the report (0: none, nothing computed)
    bool quiet = false;
    bool dry_run = false;
    LimitArgs limits;
};

int run_calibrate(const CalibrateArgs &a)
{
    if (a.dry_run)
        return dry_run(a.scene, a.limits);
    if (a.table.empty())
        throw std::runtime_error("calibrate: --output TABLE.htab is required (unless --dry-run)");
    if (a.modes != 0 && a.report.empty())
        throw std::runtime_error("calibrate: --modes shows the modes in the report: give --report DIR too");
    const auto t0 = Clock::now();
    pipeline::CalibrationInput in = input_from_scene(a.scene, a.limits, false);
    if (a.modes != 0)
        check_modes_fit(a.scene, *in.plate, a.modes, a.limits.limits());
    Progress progress(a.quiet);
    const auto &g = in.plate->grid();
    progress.note("scene " + in.scene_name + ": grid " + std::to_string(g.nx) + " x " + std::to_string(g.ny) +
                  " cells of " + std::to_string(g.h * 1e3).substr(0, 5) + " mm, " +
                  std::to_string(in.foci.points.size()) + " foci, " + std::to_string(in.exciters.count) + " exciters");
    { // which effects run, and what leaving the others out costs (docs/effects.md)
        const double f_hi = pipeline::pulse_max_frequency_hz(in.pulse);
        const double f_lo = std::max(2 * in.pulse.centre_hz - f_hi, 0.25 * in.pulse.centre_hz);
        for (const std::string &line : report::describe_effects(
                 report::assess_effects(in.effects, in.plate->params(), f_lo, f_hi, report::EffectSupport{true, true})))
            progress.note(line);
    }
    progress.note(std::string("drive design: ") +
                  (in.calibration.method == pipeline::DriveMethod::inverse_filter
                       ? "inverse filter, regularization " + fmt("%g", in.calibration.regularization)
                       : std::string("time reversal")) +
                  ", focal peak aimed at " + fmt("%.1f ms", 1e3 * pipeline::target_lead_time_s(in)) +
                  " after playback starts" +
                  (in.calibration.active_damping_s > 0
                       ? fmt(", the drive damping the plate %.1f ms after it", 1e3 * in.calibration.active_damping_s)
                       : std::string()));
    pipeline::CalibrationResult r = pipeline::calibrate(in, progress.callback());
    pipeline::write_table(a.table, in, r);
    const pipeline::PlacementReport &p = r.placement;
    progress.note("placement: " + std::to_string(p.simulations) + " simulations, " +
                  (p.focus_subset.size() == in.foci.points.size()
                       ? std::string("every focus weighed")
                       : std::to_string(p.focus_subset.size()) + " of " + std::to_string(in.foci.points.size()) +
                             " foci weighed (farthest-point subset, every focus within " +
                             fmt("%.0f mm", p.subset_cover_m * 1e3) + " of one)"));
    {
        const pipeline::StageTimes &st = r.times;
        progress.note("stages: placement simulations " + fmt("%.2f s", st.simulation_s) +
                      " (of which the site recordings resampled to the search rate " +
                      fmt("%.2f s", st.site_responses_s) + "), search " + fmt("%.2f s", st.search_s) +
                      ", transfer matrix " + fmt("%.2f s", st.transfer_s) + ", signals " + fmt("%.2f s", st.signals_s) +
                      ", verification " + fmt("%.2f s", st.verification_s) +
                      (st.verdict_s > 0 ? ", search by the verdict " + fmt("%.2f s", st.verdict_s) +
                                              " (the chosen placement's transfer, signals and verification included)"
                                        : std::string()));
    }
    if (!p.judged.empty()) { // the search by the verdict (pipeline/placement_verdict.h)
        const auto judged = [&](const pipeline::PlacementReport::Judged &j) {
            return std::to_string(j.passing) + " of " + std::to_string(in.foci.points.size()) + " foci pass, worst " +
                   fmt("%.2f dB", j.worst_whole_area_db);
        };
        const pipeline::PlacementReport::Judged *regular = nullptr, *chosen = nullptr;
        for (const pipeline::PlacementReport::Judged &j : p.judged) {
            if (j.regular)
                regular = &j;
            if (j.chosen == p.chosen)
                chosen = &j;
        }
        std::string line = "placement by the verdict: " + std::to_string(p.judged.size()) + " placements judged (" +
                           std::to_string(p.ghost_probes.size()) + " ghosts added to the model) in " +
                           fmt("%.2f s", p.verdict_s) + "; chosen: " + (chosen ? judged(*chosen) : "?");
        if (regular)
            line += "; regular: " + judged(*regular);
        progress.note(line);
        if (p.proxy_pairs > 0)
            progress.note("placement: the contrast model (foci only) ranked " + std::to_string(p.proxy_agreements) +
                          " of " + std::to_string(p.proxy_pairs) + " pairs of judged placements as the verdict did");
    }
    if (!p.regular.empty())
        progress.note("placement: predicted worst-case contrast " + std::to_string(p.chosen_contrast_db).substr(0, 5) +
                      " dB chosen vs " + std::to_string(p.regular_contrast_db).substr(0, 5) +
                      " dB regular; distance variety " + std::to_string(p.chosen_variety).substr(0, 4) + " vs " +
                      std::to_string(p.regular_variety).substr(0, 4));
    if (!a.quiet)
        print_summary(r.verification, in, true);
    if (!a.quiet && r.tolerance)
        std::fprintf(stderr, "%s", report::tolerance_text(*r.tolerance, r.verification.foci.size()).c_str());
    if (!a.report.empty()) {
        std::optional<engine::PlateModes> modes;
        if (a.modes != 0) {
            const auto tm = Clock::now();
            modes = engine::lowest_modes(*in.plate, a.modes);
            progress.note("modes: " + std::to_string(a.modes) + " lowest, " + fmt("%.4g", modes->frequency_hz.front()) +
                          " to " + fmt("%.4g Hz", modes->frequency_hz.back()) + " in " +
                          fmt("%.2f s", std::chrono::duration<double>(Clock::now() - tm).count()));
        }
        report::ReportContext ctx;
        ctx.modes = modes ? &*modes : nullptr;
        ctx.input = &in;
        ctx.result = &r;
        ctx.verification = &r.verification;
        ctx.exciters = r.exciters;
        ctx.table_path = a.table;
        ctx.scene_path = a.scene;
        std::vector<std::vector<int16_t>> stored;
        for (const pipeline::DriveSignals &d : r.signals)
            stored.push_back(d.samples);
        ctx.signals = &stored;
        ctx.signal_rate_hz = in.calibration.output_rate_hz;
        ctx.total_s = std::chrono::duration<double>(Clock::now() - t0).count();
        ctx.peak_rss_mb = model::peak_rss_mb();
        report::write_metrics_json(a.report, ctx);
        report::write_html_report(a.report, ctx);
    }
    progress.note("wrote " + a.table + (a.report.empty() ? "" : " and " + a.report + "/index.html") + " in " +
                  std::to_string(std::chrono::duration<double>(Clock::now() - t0).count()).substr(0, 5) +
                  " s, peak memory " + std::to_string(model::peak_rss_mb()).substr(0, 5) + " MB");
    // The table is written either way (to inspect, or to verify on another
    // plate); a table that fails the verdict says so in its exit status.
    return all_good(r.verification) ? 0 : 3;
}

struct VerifyArgs {
    std::string scene, table, report, drive, expect;
    bool quiet = false;
    bool scene_exciters = false; // the scene's fixed placement (the panel as it is), not the table's
    LimitArgs limits;
};

// "0.0:5,0.5:1": from each time (s), until the next, focus ID must peak highest.
std::vector<std::pair<double, uint32_t>> parse_expect(const std::string &s)
{
    std::vector<std::pair<double, uint32_t>> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        double t;
        unsigned id;
        char colon;
        std::istringstream is(item);
        if (!(is >> t >> colon >> id) || colon != ':' || t < 0)
            throw std::runtime_error("--expect: \"" + item + "\" is not TIME_S:FOCUS_ID");
        out.push_back({t, id});
    }
    return out;
}

int run_verify(const VerifyArgs &a)
{
    const auto t0 = Clock::now();
    pipeline::CalibrationInput in = input_from_scene(a.scene, a.limits, true);
    haptic_table t{};
    haptic_table_error err{};
    if (haptic_table_open(a.table.c_str(), &t, &err) != 0)
        throw std::runtime_error(a.table + ": " + err.message);
    std::unique_ptr<haptic_table, void (*)(haptic_table *)> guard(&t, haptic_table_close);
    std::vector<pipeline::Point> exciters(t.channel_count);
    for (uint32_t c = 0; c < t.channel_count; c++)
        haptic_table_channel_position(&t, c, &exciters[c].x_m, &exciters[c].y_m);
    if (a.scene_exciters) {
        if (in.exciters.placement != pipeline::PlacementMode::fixed || in.exciters.positions.size() != t.channel_count)
            throw std::runtime_error(a.scene +
                                     ": exciters: --exciters scene needs placement = \"fixed\" with one "
                                     "position per table channel (" +
                                     std::to_string(t.channel_count) + ")");
        exciters = in.exciters.positions;
    }
    // The table's foci must be the scene's, in the scene's order.
    if (t.focus_count != in.foci.points.size())
        throw std::runtime_error(a.table + ": " + std::to_string(t.focus_count) + " foci, the scene has " +
                                 std::to_string(in.foci.points.size()));
    std::vector<std::vector<int16_t>> signals;
    for (uint32_t f = 0; f < t.focus_count; f++) {
        haptic_focus_info fi;
        haptic_table_focus(&t, f, &fi);
        const pipeline::FocusPoint &sf = in.foci.points[f];
        if (fi.id != sf.id || pipeline::dist({fi.x_m, fi.y_m}, sf.at) > 1e-6)
            throw std::runtime_error(a.table + ": focus " + std::to_string(f) + " (id " + std::to_string(fi.id) +
                                     ") does not match the scene's focus id " + std::to_string(sf.id));
        const int16_t *s = haptic_table_signal(&t, f);
        signals.emplace_back(s, s + static_cast<size_t>(t.samples_per_signal) * t.channel_count);
    }
    Progress progress(a.quiet);
    pipeline::Verification v;
    bool ok = true;
    std::string mode = "table";
    if (a.drive.empty()) {
        v = pipeline::verify_signals(in, exciters, signals, t.sample_rate_hz, progress.callback());
        ok = all_good(v);
    } else {
        mode = "drive";
        SF_INFO info{};
        SNDFILE *snd = sf_open(a.drive.c_str(), SFM_READ, &info);
        if (!snd)
            throw std::runtime_error(a.drive + ": " + sf_strerror(nullptr));
        std::vector<float> frames(static_cast<size_t>(info.frames) * static_cast<size_t>(info.channels));
        const sf_count_t got = sf_readf_float(snd, frames.data(), info.frames);
        sf_close(snd);
        if (got != info.frames)
            throw std::runtime_error(a.drive + ": short read");
        if (static_cast<unsigned>(info.channels) != t.channel_count)
            throw std::runtime_error(a.drive + ": " + std::to_string(info.channels) + " channels, the table has " +
                                     std::to_string(t.channel_count));
        v = pipeline::verify_drive(in, exciters, frames, static_cast<unsigned>(info.channels), info.samplerate,
                                   progress.callback());
        // Each expected trigger: within its window, the asked focus peaks highest and crosses the threshold.
        const auto expect = parse_expect(a.expect);
        const std::vector<std::vector<double>> &tr = v.traces[0];
        for (size_t e = 0; e < expect.size(); e++) {
            const double t_from = expect[e].first;
            const double t_to = e + 1 < expect.size() ? expect[e + 1].first : 1e30;
            const auto n0 = static_cast<size_t>(t_from * v.trace_rate_hz);
            const auto n1 = static_cast<size_t>(std::min(t_to * v.trace_rate_hz, double(tr[0].size())));
            uint32_t best_id = 0;
            double best = -1, asked = 0;
            for (size_t g = 0; g < tr.size(); g++) {
                double peak = 0;
                for (size_t n = n0; n < n1 && n < tr[g].size(); n++)
                    peak = std::max(peak, std::abs(tr[g][n]));
                if (peak > best) {
                    best = peak;
                    best_id = in.foci.points[g].id;
                }
                if (in.foci.points[g].id == expect[e].second)
                    asked = peak;
            }
            const bool hit = best_id == expect[e].second && asked >= in.calibration.threshold_m;
            ok &= hit;
            std::fprintf(stderr, "drive from %.3f s: focus %u asked, focus %u peaks highest (%.2f um) %s\n", t_from,
                         expect[e].second, best_id, best * 1e6, hit ? "ok" : "MISMATCH");
        }
    }
    if (!a.quiet)
        print_summary(v, in, mode == "table");
    if (!a.report.empty()) {
        report::ReportContext ctx;
        ctx.input = &in;
        ctx.verification = &v;
        ctx.exciters = exciters;
        ctx.table_path = a.table;
        ctx.scene_path = a.scene;
        ctx.mode = mode;
        ctx.signals = &signals;
        ctx.signal_rate_hz = t.sample_rate_hz;
        ctx.total_s = std::chrono::duration<double>(Clock::now() - t0).count();
        ctx.peak_rss_mb = model::peak_rss_mb();
        report::write_metrics_json(a.report, ctx);
        report::write_html_report(a.report, ctx);
    }
    std::fprintf(stderr, "verify: %s\n",
                 ok ? (mode == "table" ? "every focus passes the verdict" : "every trigger played its focus")
                    : "NOT met (see above): exit status 3");
    return ok ? 0 : 3;
}

} // namespace

void register_calibrate(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<CalibrateArgs>();
    CLI::App *cmd = app.add_subcommand(
        "calibrate", "Simulate, place exciters, write the table, verify; exit 3 when a focus fails the verdict");
    cmd->add_option("scene", a->scene, "Scene file (TOML)")->required();
    cmd->add_option("-o,--output", a->table, "Table to write (.htab); required unless --dry-run");
    cmd->add_flag("--dry-run", a->dry_run, "Print the chosen setting, predicted error, time and memory; run nothing");
    cmd->add_option("--report", a->report, "Directory for metrics.json and index.html");
    cmd->add_option("--modes", a->modes,
                    "Also show the plate's N lowest eigenmodes in the report (as `calibgen modes`)");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress or summary on stderr");
    add_limit_options(cmd, a->limits);
    cmd->callback([a, &exit_code] { exit_code = run_calibrate(*a); });
}

void register_verify(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<VerifyArgs>();
    CLI::App *cmd = app.add_subcommand(
        "verify", "Forward-simulate a table's quantized signals (or a device recording) and measure every focus; "
                  "exit 3 when a focus fails the verdict");
    cmd->add_option("scene", a->scene, "Scene file (TOML)")->required();
    cmd->add_option("table", a->table, "Table (.htab)")->required();
    cmd->add_option("--report", a->report, "Directory for metrics.json and index.html");
    cmd->add_option("--drive", a->drive, "Multichannel WAV the device played, simulated instead of the table");
    cmd->add_option("--expect", a->expect, "With --drive: TIME_S:FOCUS_ID,... the focus each trigger asked for");
    cmd->add_option_function<std::string>(
           "--exciters", [a](const std::string &v) { a->scene_exciters = v == "scene"; },
           "Where the exciters are: 'table' (default: where the table was calibrated for) or 'scene' (the "
           "scene's fixed placement and force gains: a panel as measured, e.g. a bench fit's truth)")
        ->check(CLI::IsMember({"table", "scene"}));
    cmd->add_flag("-q,--quiet", a->quiet, "No progress or summary on stderr");
    add_limit_options(cmd, a->limits);
    cmd->callback([a, &exit_code] { exit_code = run_verify(*a); });
}

} // namespace calib::app
