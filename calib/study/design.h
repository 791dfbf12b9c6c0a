// `calibgen study design SWEEP.toml --report DIR`: every case of a sweep
// (study/sweep.h) through calibration and verification, locally or spread
// over the ranks of an MPI job (study/workers.h), one result file per case
// in DIR/cases/ as soon as it is done, then the report (study/design_report.h).
// A rerun skips the cases whose result file exists: an interrupted sweep
// (a killed rank, a lost machine) resumes where it stopped.
#pragma once
#include <string>

namespace calib::study {

struct DesignOptions {
    std::string sweep_path, report_dir;
    int threads = 0; // per rank; 0: this machine's cores shared among its ranks
    bool quiet = false;
};

// Returns the exit code: 0 when the report is written (refused cases are
// part of the report). Throws for a sweep that cannot be run (one line).
int run_design_study(const DesignOptions &options);

} // namespace calib::study
