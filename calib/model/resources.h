// What this machine allows, and the refusal of work that would not fit:
// checked before any simulation (calibrate, verify, simulate), so a scene
// that would exhaust memory stops in a second with one line naming the
// scene key to change, instead of being killed after minutes.
#pragma once
#include "model/cost_model.h"
#include "scene/scene.h"

#include <optional>
#include <string>

namespace calib::model {

struct Limits {
    double memory_mb = 0;          // refuse when the predicted peak exceeds this
    std::string memory_source;     // "physical memory" or "--max-memory"
    std::optional<double> seconds; // refuse when the predicted time exceeds this (--max-seconds)
};
// Physical memory (sysconf) unless `max_memory_mb` is given; no time limit
// unless `max_seconds` is given.
Limits machine_limits(std::optional<double> max_memory_mb, std::optional<double> max_seconds);

// Throws std::runtime_error, one line: "<what>: predicted <memory> MB and
// <time> s exceed <limit> (<source>): <cause>; change <key>". `cause_key` names
// the scene key that drives the dominant cost.
void refuse_if_over(const std::string &what, double memory_mb, double seconds, const Limits &limits,
                    const std::string &cause_key);

// For a calibration: which scene key drives the predicted memory (the
// recordings at the candidate sites, or the grid).
std::string calibration_cause(const pipeline::CalibrationInput &in, const pipeline::CalibrationPlan &plan,
                              const Prediction &p, bool verification_only = false);

// Plans and prices a calibration (or, `verification_only`, what `verify`
// runs) and refuses it (std::runtime_error, one line starting with `what`)
// when it is over the limits. The cost model is timed (a quick, reduced
// timing) only when the answer needs a time: a refusal, or a time limit.
struct Priced {
    pipeline::CalibrationPlan plan;
    Prediction prediction;
};
Priced refuse_unaffordable(const pipeline::CalibrationInput &in, const Limits &limits, const std::string &what,
                           bool verification_only = false);

// The same refusal from the scene alone, before its operator is built (on a
// large grid the build and its stability bound take many seconds): the grid,
// the interior stability bound (never below the operator's, so the steps are
// a lower bound), the candidate sites and the foci give a lower bound of the
// memory, and a quick timing on a small plate a lower bound of the time.
// Grids past the engine's size limit are refused naming their cell count.
// `calibration` false: one simulation of `steps_s` seconds with `receivers`.
void refuse_before_build(const scene::Scene &s, const Limits &limits, bool calibration, double duration_s = 0,
                         std::size_t receivers = 0);

// Resident memory of this process (MB): now, and the peak since the last
// reset_peak_rss() (Linux VmRSS and VmHWM; the reset first returns freed
// heap to the system with malloc_trim, so the next peak counts what a run needs).
double current_rss_mb();
double peak_rss_mb();
void reset_peak_rss();

} // namespace calib::model
