// The report of a design sweep, assembled from the per-case results in case
// order (so it does not depend on which rank ran what, nor when):
//   design.csv   one row per case: inputs and figures (compared across runs)
//   timing.csv   one row per case: wall time, stages, peak memory, rank
//                (machine- and load-dependent, kept apart on purpose)
//   contrast_vs_exciters.{svg,png}, spot_vs_frequency.{svg,png}
//   summary.md   the best case per constraint, and every case in a table
#pragma once
#include "study/design_case.h"
#include "study/sweep.h"

#include <string>
#include <vector>

namespace calib::study {

std::string design_csv(const std::vector<CaseResult> &cases);
std::string timing_csv(const std::vector<CaseResult> &cases);
std::string design_summary(const Sweep &sweep, const std::vector<CaseResult> &cases);

// Writes every file above into `dir` (atomically each); returns the summary.
std::string write_design_report(const Sweep &sweep, const std::vector<CaseResult> &cases, const std::string &dir);

} // namespace calib::study
