#include "pipeline/calibrate_stages.h"

#include "pipeline/design/finishing.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/design/time_reversal.h"
#include "pipeline/robustness/robust_design.h"
#include "pipeline/robustness/tolerance_stage.h"
#include "pipeline/verification/radiation.h"
#include "pipeline/verification/verification.h"

#include <algorithm>
#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

} // namespace

void signals_and_verification(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                              CalibrationResult &res, bool judge_only)
{
    // 4. Drive signals from H: time reversal or the inverse filter.
    auto t0 = Clock::now();
    res.signals = in.calibration.method == DriveMethod::inverse_filter ? inverse_filter_signals(in, H, progress)
                                                                       : signals_from_transfer(in, H, progress);
    // A robust design (the same method over the ensemble of plates) replaces
    // them; the plain design stays for the comparison.
    std::vector<DriveSignals> plain;
    std::optional<RobustDesign> robust;
    if (in.robust && !judge_only) {
        robust = robust_design(in, H, progress);
        plain = std::move(res.signals);
        res.signals = robust->signals;
    }
    if (in.effects.exciter && in.effects.exciter->precompensate)
        for (size_t f = 0; f < res.signals.size(); f++) {
            precompensate_for_exciter(res.signals[f], *in.effects.exciter, drive_options(in, f));
            if (f < plain.size())
                precompensate_for_exciter(plain[f], *in.effects.exciter, drive_options(in, f));
        }
    res.times.signals_s = seconds_since(t0);

    // 5. Playback level: each focus is stored at the level that gives the
    //    scene's target amplitude (never above full scale), so the device plays
    //    the pulse the scene asks for; linearity gives it from the full-scale
    //    peak. Then the verification of the signals exactly as stored.
    t0 = Clock::now();
    const bool lti = transfer_holds(in);
    res.full_scale_peak_m =
        lti ? focal_peaks(in, H, stored_samples(res.signals), in.calibration.output_rate_hz) : std::vector<double>{};
    if (!lti) {
        const Verification full = verify_signals_forward(in, res.exciters, stored_samples(res.signals),
                                                         in.calibration.output_rate_hz, progress, false);
        for (const FocusMetrics &m : full.foci)
            res.full_scale_peak_m.push_back(m.peak_m);
    }
    for (size_t f = 0; f < res.signals.size(); f++) {
        if (!(res.full_scale_peak_m[f] > 0))
            throw std::runtime_error("focus " + std::to_string(in.foci.points[f].id) +
                                     ": the exciters produce no displacement there");
        const double amplitude = robust && !robust->amplitude_m.empty() ? robust->amplitude_m[f] : in.pulse.amplitude_m;
        requantize(res.signals[f], std::min(1.0, amplitude / res.full_scale_peak_m[f]), drive_options(in, f));
    }
    const std::vector<std::vector<int16_t>> stored = stored_samples(res.signals); // as the table holds them
    res.verification =
        lti ? verify_signals_with(in, H, stored, in.calibration.output_rate_hz, progress)
            : verify_signals_forward(in, res.exciters, stored, in.calibration.output_rate_hz, progress, true);
    res.times.verification_s = seconds_since(t0);
    if (!judge_only)
        finish_stages(in, H, progress, res, std::move(plain), robust ? &*robust : nullptr);
}

void finish_stages(const CalibrationInput &in, const TransferMatrix &H, const ProgressFn &progress,
                   CalibrationResult &res, std::vector<DriveSignals> plain, const RobustDesign *robust)
{
    // What a listener hears of each focus (verification/radiation.h): from H's lattice.
    if (transfer_holds(in) && H.lattice.size() > 0) {
        const auto t1 = Clock::now();
        const std::vector<RadiatedSound> sound =
            radiated_sounds(in, H, stored_samples(res.signals), in.calibration.output_rate_hz);
        for (size_t f = 0; f < res.verification.foci.size() && f < sound.size(); f++) {
            res.verification.foci[f].sound_exposure_dba = sound[f].exposure_level_dba;
            res.verification.foci[f].sound = true;
        }
        res.times.sound_s = seconds_since(t1);
        res.times.verification_s += res.times.sound_s;
    }

    // 6. The table over the scene's tolerance box (robustness/tolerance_stage.h).
    if (in.tolerance || in.robust)
        res.tolerance = tolerance_stage(in, H, res, std::move(plain), robust, progress);
}

} // namespace calib::pipeline
