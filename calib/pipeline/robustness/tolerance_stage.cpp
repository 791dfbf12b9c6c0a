#include "pipeline/robustness/tolerance_stage.h"

#include "pipeline/design/finishing.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/verification/verification.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

std::vector<std::vector<int16_t>> level_as_stored(const CalibrationInput &in, const TransferMatrix &H,
                                                  std::vector<DriveSignals> signals)
{
    const std::vector<double> peak = focal_peaks(in, H, stored_samples(signals), in.calibration.output_rate_hz);
    for (std::size_t f = 0; f < signals.size(); f++) {
        if (!(peak[f] > 0))
            throw std::runtime_error("focus " + std::to_string(in.foci.points[f].id) +
                                     ": the exciters produce no displacement there");
        requantize(signals[f], std::min(1.0, in.pulse.amplitude_m / peak[f]), drive_options(in, f)); // as calibrate()
    }
    return stored_samples(signals);
}

ToleranceReport tolerance_stage(const CalibrationInput &in, const TransferMatrix &H, const CalibrationResult &res,
                                std::vector<DriveSignals> plain, const RobustDesign *robust, const ProgressFn &progress)
{
    const auto t0 = std::chrono::steady_clock::now();
    const double rate = in.calibration.output_rate_hz, F = in.exciters.force_full_scale_n;
    ToleranceReport r;
    const StoredTable table{stored_samples(res.signals), rate};
    r.nominal = figures_of(res.verification, table.signals, F, rate);
    std::optional<StoredTable> other;
    if (robust) {
        other = StoredTable{level_as_stored(in, H, std::move(plain)), rate};
        r.nominal_design = figures_of(verify_signals_with(in, H, other->signals, rate), other->signals, F, rate);
        for (const Perturbation &m : robust->members)
            r.ensemble.push_back(m.name);
        r.ensemble_seconds = robust->seconds;
    }
    std::vector<Perturbation> cases;
    if (in.tolerance) {
        cases = one_at_a_time(in, *in.tolerance);
        for (Perturbation &p : random_combinations(in, *in.tolerance, in.tolerance->random_cases, in.tolerance->seed))
            cases.push_back(std::move(p));
    } else if (robust) {
        cases = robust->members;
    }
    r.cases = evaluate_cases(in, res.exciters, cases, table, other ? &*other : nullptr, progress, &H);
    std::vector<CaseFigures> mine{r.nominal}, theirs;
    if (r.nominal_design)
        theirs.push_back(*r.nominal_design);
    for (const ToleranceCase &c : r.cases) {
        mine.push_back(c.table);
        if (c.nominal_design)
            theirs.push_back(*c.nominal_design);
    }
    r.worst = worst_of(mine);
    if (!theirs.empty())
        r.nominal_design_worst = worst_of(theirs);
    if (in.tolerance && in.tolerance->speed_compensation) {
        // The box as the device meets it: each plate at its speed ratio.
        std::vector<CaseFigures> mine_c{r.nominal}, theirs_c;
        if (r.nominal_design)
            theirs_c.push_back(*r.nominal_design);
        for (const ToleranceCase &c : r.cases) {
            mine_c.push_back(c.compensated.value_or(c.table));
            if (c.nominal_design)
                theirs_c.push_back(c.nominal_design_compensated.value_or(*c.nominal_design));
        }
        r.compensated_worst = worst_of(mine_c);
        if (!theirs_c.empty())
            r.nominal_design_compensated_worst = worst_of(theirs_c);
    }
    r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return r;
}

} // namespace calib::pipeline
