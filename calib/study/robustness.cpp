#include "study/robustness.h"

#include "io/read_file.h"
#include "scene/calibration_input.h"

#include <chrono>
#include <stdexcept>

namespace calib::study {

pipeline::ToleranceSpec default_tolerance()
{
    pipeline::ToleranceSpec t;
    t.youngs_rel = 0.03;
    t.density_rel = 0.03;
    t.thickness_rel = 0.05;
    t.loss_scale = {0.5, 2.0};
    t.exciter_position_m = 0.002;
    t.temperature_k = 10;
    t.random_cases = 8;
    return t;
}

RobustnessResult run_robustness_study(const RobustnessOptions &o, const StudyLog &log)
{
    const std::optional<std::string> bytes = io::read_file(o.scene_path);
    if (!bytes)
        throw std::runtime_error(o.scene_path + ": cannot open scene file");
    pipeline::CalibrationInput in = scene::calibration_input(*bytes, o.scene_path);
    RobustnessResult r;
    r.scene_name = in.scene_name;
    r.scene_path = o.scene_path;
    r.default_box = !in.tolerance;
    if (!in.tolerance)
        in.tolerance = default_tolerance();
    if (o.random_cases)
        in.tolerance->random_cases = *o.random_cases;
    if (o.seed)
        in.tolerance->seed = *o.seed;
    try {
        pipeline::check_feasible(in); // the box included
    } catch (const std::invalid_argument &e) {
        throw std::runtime_error(o.scene_path + ": " + e.what());
    }
    r.box = pipeline::resolve_tolerance(in, *in.tolerance);
    r.robust = in.robust.has_value();
    r.foci = in.foci.points.size();
    const pipeline::CalibrationResult res =
        pipeline::calibrate(in, [&](const std::string &s, size_t done, size_t total) {
            if (log && (done == total || s == "tolerance"))
                log(s + " " + std::to_string(done) + "/" + std::to_string(total));
        });
    if (!res.tolerance)
        throw std::logic_error("calibrate returned no tolerance report");
    r.report = *res.tolerance;
    const pipeline::StageTimes &t = res.times;
    // A single (plain) calibration: its stages without the robust ensemble.
    r.calibration_s =
        t.simulation_s + t.search_s + t.transfer_s + t.signals_s + t.verification_s - r.report.ensemble_seconds;
    for (const pipeline::ToleranceCase &c : r.report.cases)
        (c.perturbation.factor == "combined" ? r.random_s : r.one_at_a_time_s) += c.seconds;
    return r;
}

} // namespace calib::study
