// One case of a design sweep: the case's scene through the whole calibration
// and its verification (pipeline::calibrate), reduced to the figures an
// integrator compares, and the per-case result file that makes a sweep
// resumable: written atomically once the case is done, named by the case id.
#pragma once
#include "study/sweep.h"

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace calib::study {

struct CaseResult {
    std::size_t index = 0;
    std::string id;
    // Inputs, read back from the case's scene (every case row is self-describing).
    std::string material, edges, criterion;
    double thickness_m = 0, pulse_centre_hz = 0, pulse_cycles = 0;
    unsigned exciters = 0;
    uint64_t seed = 0;
    // Outcome: `ran` false means refused or failed, with the one-line reason in `note`.
    bool ran = false;
    std::string note;
    // Figures, worst over the foci (the integrator's guarantee is the worst focus).
    unsigned foci = 0;
    unsigned foci_meeting_criterion = 0; // focus crosses the threshold, every other focus stays below it
    double worst_contrast_db = 0;        // min over foci: focal peak over the other foci, all times
    double min_peak_m = 0;               // min over foci: focal peak at full scale
    // min over foci: focal peak at full scale per square root of the drive
    // energy sum_c sum_n F^2 / rate (N^2 s), F the force at each exciter: the
    // matched-filter efficiency, independent of the drive level.
    double min_peak_per_sqrt_energy = 0; // m / (N s^0.5)
    double max_spot_m = 0;               // max over foci: half-peak spot diameter
    double max_lead_time_s = 0;          // max over foci: drive start to focal peak
    // Cost, which depends on the machine and its load: kept out of the compared CSV.
    double wall_s = 0, simulation_s = 0, search_s = 0, verification_s = 0, peak_rss_mb = 0;
    int rank = 0;
};

// Runs one case. A case the pipeline refuses (an infeasible exciter count, a
// value the scene parser rejects) or that fails is returned with ran = false
// and the reason: one bad corner of a sweep does not stop the others.
CaseResult run_case(const Sweep &sweep, const Case &c, int rank);

// The per-case result file: "key=value" lines, numbers with 17 significant
// digits (the report reads them back exactly).
std::string case_file_name(const Case &c); // "<id>.case"
std::string encode_case(const CaseResult &r);
// Throws std::runtime_error naming `file` for a file that is not a whole case record.
CaseResult decode_case(std::string_view text, const std::string &file);

} // namespace calib::study
