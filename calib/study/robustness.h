// `calibgen study robustness SCENE --report DIR`: calibrate on the nominal
// plate, then verify the same table on perturbed plates, each from its own
// transfer matrix: every tolerance at both ends of its range one at a time,
// then seeded random combinations (docs/robustness.md). The box is the
// scene's [tolerance], or the default below when it has none. Writes
// robustness.csv, a tornado plot (robustness_tornado.svg/.png: which
// tolerance costs most whole-area contrast) and robustness.md.
#pragma once
#include "pipeline/calibrate.h"
#include "pipeline/robustness/tolerance.h"

#include <functional>
#include <optional>
#include <string>

namespace calib::study {

struct RobustnessOptions {
    std::string scene_path, report_dir;
    std::optional<unsigned> random_cases; // overrides the box's (default 8)
    std::optional<uint64_t> seed;
    bool quiet = false;
};

struct RobustnessResult {
    std::string scene_name, scene_path;
    pipeline::ResolvedTolerance box;
    bool default_box = false; // the scene had no [tolerance]
    bool robust = false;      // the table is a robust design (plain design beside it)
    pipeline::ToleranceReport report;
    double calibration_s = 0; // the calibration alone (its stages)
    double one_at_a_time_s = 0, random_s = 0;
    std::size_t foci = 0;
};

// The box a scene without [tolerance] is studied over: E and rho +-3 %,
// thickness +-5 %, the material's loss range and the loss x0.5 and x2,
// exciters +-2 mm, +-10 K through the material's dE/dT, 8 random plates.
pipeline::ToleranceSpec default_tolerance();

using StudyLog = std::function<void(const std::string &)>;
RobustnessResult run_robustness_study(const RobustnessOptions &o, const StudyLog &log = {});
// Writes the CSV, the plot and the summary into dir; returns the summary (markdown).
std::string write_robustness_report(const RobustnessResult &r, const std::string &dir);

} // namespace calib::study
