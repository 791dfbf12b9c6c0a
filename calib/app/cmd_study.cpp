// `calibgen study accuracy SCENE.toml --report DIR`: what accuracy costs in
// time and memory (calib/study/accuracy.h, docs/ACCURACY.md).
// `calibgen study design SWEEP.toml --report DIR`: design choices swept
// through the whole calibration (calib/study/design.h, docs/design-studies.md).
// `calibgen study latency SCENE --report DIR`: lead time against focusing for
// time reversal and the inverse filter (calib/study/latency.h).
// `calibgen study robustness SCENE.toml --report DIR`: one table verified over
// a tolerance box of perturbed plates (calib/study/robustness.h, docs/robustness.md).
#include "app/commands.h"
#include "io/format.h"
#include "study/accuracy.h"
#include "study/design.h"
#include "study/latency.h"
#include "study/robustness.h"

#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <stdexcept>

namespace calib::app {

namespace {

struct StudyArgs {
    std::string scene, report, ppw;
    unsigned restarts = 2, iterations = 300;
    bool quiet = false, ppw_only = false;
};

std::vector<double> parse_list(const std::string &s, const char *option, double lo = 4, double hi = 200)
{
    std::vector<double> v;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        char *end = nullptr;
        const double x = std::strtod(item.c_str(), &end);
        if (item.empty() || *end != '\0' || !(x >= lo && x <= hi))
            throw std::runtime_error(std::string(option) + ": \"" + item + "\" is not a number in [" +
                                     io::fmt("%g", lo) + ", " + io::fmt("%g", hi) + "]");
        v.push_back(x);
    }
    return v;
}

struct LatencyArgs {
    std::string scene, report, leads_ms, regs;
    bool quiet = false, no_pairs = false, triples = false, joint = false;
};

int run_study_latency(const LatencyArgs &a)
{
    study::LatencyOptions o;
    if (!a.leads_ms.empty()) {
        o.lead_times_s = parse_list(a.leads_ms, "--lead-ms", 1, 1000);
        for (double &x : o.lead_times_s)
            x *= 1e-3;
    }
    if (!a.regs.empty())
        o.regularizations = parse_list(a.regs, "--regularization", 0, 1e6);
    o.quiet = a.quiet;
    o.multitouch = !a.no_pairs;
    o.triples = a.triples && !a.no_pairs;
    o.joint = a.joint && !a.no_pairs;
    const study::LatencyResult r = study::run_latency_study(a.scene, o, [&](const std::string &line) {
        if (!a.quiet)
            std::fprintf(stderr, "%s\n", line.c_str());
    });
    const std::string md = study::write_latency_report(r, a.report);
    std::printf("%s", md.c_str());
    std::fprintf(stderr, "wrote %s/latency.{csv,svg,png,md} and latency-efficiency.svg%s\n", a.report.c_str(),
                 std::filesystem::exists(a.report + "/multitouch.csv")
                     ? " (multitouch.csv, .svg, .png with joint designs)"
                     : "");
    return 0;
}

int run_study_accuracy(const StudyArgs &a)
{
    study::StudyOptions o;
    if (!a.ppw.empty())
        o.points_per_wavelength = parse_list(a.ppw, "--ppw");
    o.search_restarts = a.restarts;
    o.search_iterations = a.iterations;
    o.quiet = a.quiet;
    if (a.ppw_only) {
        o.courants.clear();
        o.window_factors.clear();
        o.include_precision = o.include_model = false;
    }
    const study::StudyResult r = study::run_accuracy_study(a.scene, o, [&](const std::string &line) {
        if (!a.quiet)
            std::fprintf(stderr, "%s\n", line.c_str());
    });
    const std::string md = study::write_study_report(r, a.report);
    std::printf("%s", md.c_str());
    std::fprintf(stderr, "wrote %s/accuracy.{csv,svg,png,md}\n", a.report.c_str());
    return 0;
}

} // namespace

void register_study(CLI::App &app, int &exit_code)
{
    CLI::App *study = app.add_subcommand("study", "Studies of the simulation itself");
    study->require_subcommand(1);
    auto a = std::make_shared<StudyArgs>();
    CLI::App *cmd = study->add_subcommand(
        "accuracy", "Sweep points per wavelength, precision, Courant factor, window and model: phase-velocity "
                    "error (measured), focus change, time and memory; CSV, plot and table");
    cmd->add_option("scene", a->scene, "Calibration scene (TOML)")->required();
    cmd->add_option("--report", a->report, "Directory for accuracy.csv, .svg, .png, .md")->required();
    cmd->add_option("--ppw", a->ppw, "Points per wavelength to sweep (default 6,8,10,12,16,20,24)");
    cmd->add_option("--restarts", a->restarts, "Restarts of the reference's placement search (reduced budget)");
    cmd->add_option("--iterations", a->iterations, "Iterations per restart of the reference's placement search");
    cmd->add_flag("--ppw-only", a->ppw_only, "Sweep points per wavelength only (no precision, Courant, window, model)");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress on stderr");
    cmd->callback([a, &exit_code] { exit_code = run_study_accuracy(*a); });

    auto d = std::make_shared<study::DesignOptions>();
    CLI::App *design = study->add_subcommand(
        "design", "Sweep a base scene's design choices (exciter count, material, thickness, pulse, edges, placement): "
                  "one full calibration and verification per case; CSV, plots and a summary of the best cases. "
                  "Under mpirun the cases spread over the ranks; a rerun resumes an interrupted sweep");
    design->add_option("sweep", d->sweep_path, "Sweep file (TOML): base scene and [axes]")->required();
    design->add_option("--report", d->report_dir, "Directory for cases/, design.csv, timing.csv, plots, summary.md")
        ->required();
    design->add_option("--threads", d->threads, "Threads per rank (default: the cores shared among the ranks)")
        ->check(CLI::Range(1, 1024));
    design->add_flag("-q,--quiet", d->quiet, "No progress on stderr, no summary on stdout");
    design->callback([d, &exit_code] { exit_code = study::run_design_study(*d); });

    auto l = std::make_shared<LatencyArgs>();
    CLI::App *latency = study->add_subcommand(
        "latency", "Sweep the lead time (playback start to focal peak) for time reversal and the inverse filter on one "
                   "placement and transfer matrix: whole-area contrast, peak per drive energy, margin under the "
                   "threshold; CSV, plots and a markdown table");
    latency->add_option("scene", l->scene, "Calibration scene (TOML)")->required();
    latency->add_option("--report", l->report, "Directory for latency.csv, .svg, .png, .md")->required();
    latency->add_option("--lead-ms", l->leads_ms, "Lead times to sweep in ms (default 10,15,20,25,30,40,50,60,70,80)");
    latency->add_option("--regularization", l->regs, "Inverse-filter regularizations to sweep (default: the scene's)");
    latency->add_flag("--no-pairs", l->no_pairs, "Skip the two-finger verification of every pair of foci");
    latency->add_flag("--triples", l->triples, "Verify every triple of foci (three fingers) too");
    latency->add_flag("--joint", l->joint,
                      "In the inverse filter's cases, design every pair (and triple) jointly too and compare it with "
                      "the superposition (multitouch.csv, .svg, .png)");
    latency->add_flag("-q,--quiet", l->quiet, "No progress on stderr");
    latency->callback([l, &exit_code] { exit_code = run_study_latency(*l); });
    auto r = std::make_shared<study::RobustnessOptions>();
    CLI::App *rob = study->add_subcommand(
        "robustness", "Calibrate on the nominal plate, then verify the same table on perturbed plates (E, rho, "
                      "thickness, loss, exciter positions, temperature; one at a time and in seeded random "
                      "combinations), each from its own transfer matrix; CSV, tornado plot and summary");
    rob->add_option("scene", r->scene_path, "Calibration scene (TOML); its [tolerance] is the box, else the default")
        ->required();
    rob->add_option("--report", r->report_dir,
                    "Directory for robustness.csv, robustness_tornado.{svg,png}, "
                    "robustness.md")
        ->required();
    rob->add_option("--random", r->random_cases, "Random combinations (default: the box's, 8 for the default box)")
        ->check(CLI::Range(0, 10000));
    rob->add_option("--seed", r->seed, "Seed of the random combinations and exciter directions");
    rob->add_flag("-q,--quiet", r->quiet, "No progress on stderr");
    rob->callback([r, &exit_code] {
        const study::RobustnessResult res = study::run_robustness_study(*r, [&](const std::string &line) {
            if (!r->quiet)
                std::fprintf(stderr, "%s\n", line.c_str());
        });
        const std::string md = study::write_robustness_report(res, r->report_dir);
        std::printf("%s", md.c_str());
        std::fprintf(stderr, "wrote %s/robustness.{csv,md}, robustness_tornado.{svg,png}\n", r->report_dir.c_str());
        exit_code = 0;
    });
}

} // namespace calib::app
