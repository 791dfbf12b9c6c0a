#include "pipeline/table_writer.h"

#include <haptic_table.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

void write_table(const std::string &path, const CalibrationInput &in, const CalibrationResult &r)
{
    const size_t K = r.signals.size(), C = r.exciters.size();
    size_t frames = 0;
    for (const DriveSignals &d : r.signals)
        frames = std::max(frames, d.frames);
    std::vector<double> cxy, fxy, scale, lead;
    std::vector<uint32_t> ids;
    for (Point p : r.exciters)
        cxy.insert(cxy.end(), {p.x_m, p.y_m});
    std::vector<int16_t> samples(K * frames * C, 0);
    // Every figure the table stores per focus (scale_m, the lead time, the
    // safe range) is the verification's of the stored samples: a focus
    // without its figures has no table to be in (a range section is whole or
    // absent, and a range guessed for one focus would be a promise nothing
    // measured).
    if (r.verification.foci.size() != K)
        throw std::runtime_error("the verification measured " + std::to_string(r.verification.foci.size()) + " of " +
                                 std::to_string(K) + " foci: no table without every focus's figures");
    std::vector<haptic_gain_range> ranges;
    bool whole_area = true;
    for (size_t f = 0; f < K; f++) {
        const FocusMetrics &m = r.verification.foci[f];
        if (!(m.peak_m > 0) || !std::isfinite(m.peak_m))
            throw std::runtime_error("focus " + std::to_string(m.id) + ": verification found no displacement");
        ids.push_back(in.foci.points[f].id);
        fxy.insert(fxy.end(), {in.foci.points[f].at.x_m, in.foci.points[f].at.y_m});
        scale.push_back(m.peak_m);
        lead.push_back(m.lead_time_s); // the same playback as scale_m: the stored samples at gain 1
        ranges.push_back(m.gain_range(in.calibration.threshold_m)); // the same, relative to gain 1
        whole_area &= m.whole_area;
        std::copy(r.signals[f].samples.begin(), r.signals[f].samples.end(), samples.begin() + f * frames * C);
    }
    char created[32];
    const std::time_t now = std::time(nullptr);
    std::strftime(created, sizeof created, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    const std::string tool = "calibgen " HAPTIC_VERSION;
    std::string name = in.scene_name.substr(0, HAPTIC_TABLE_SCENE_NAME_LEN);
    while (!name.empty() && name.size() < in.scene_name.size() &&
           (static_cast<unsigned char>(in.scene_name[name.size()]) & 0xC0) == 0x80)
        name.pop_back(); // never cut a UTF-8 sequence: the reader refuses invalid UTF-8
    haptic_table_spec spec{};
    spec.sample_rate_hz = static_cast<uint32_t>(std::lround(in.calibration.output_rate_hz));
    spec.channel_count = static_cast<uint16_t>(C);
    spec.focus_count = static_cast<uint32_t>(K);
    spec.samples_per_signal = static_cast<uint32_t>(frames);
    spec.channel_xy_m = cxy.data();
    spec.focus_id = ids.data();
    spec.focus_xy_m = fxy.data();
    spec.focus_scale_m = scale.data();
    spec.samples = samples.data();
    spec.scene_name = name.c_str();
    spec.scene_hash = in.scene_hash.c_str();
    spec.tool_version = tool.c_str();
    spec.created_utc = created;
    // What a count means (drive() in this file): force_full_scale_n at 32767,
    // through the exciter's response when the scene models the exciter.
    spec.drive_kind = !in.effects.exciter                 ? HAPTIC_DRIVE_FORCE
                      : in.effects.exciter->precompensate ? HAPTIC_DRIVE_EXCITER_PRECOMPENSATED
                                                          : HAPTIC_DRIVE_EXCITER;
    spec.force_full_scale_n = in.exciters.force_full_scale_n;
    spec.focus_lead_time_s = lead.data();
    // The plate the drives are for, for the device's temperature compensation
    // (common/haptic_stretch.h): its temperature and dE/E/dT (the tolerance
    // box's, when the scene states one, else the material's). Left out when
    // dE/E/dT is unknown (a custom material without E_per_k): a device must
    // not take 0 for it.
    haptic_panel panel{};
    panel.temperature_c = in.plate_temperature_c;
    const bool stated = in.tolerance && in.tolerance->youngs_per_kelvin;
    panel.youngs_per_k = panel_youngs_per_kelvin(in.tolerance ? &*in.tolerance : nullptr, in.plate->params().material);
    spec.panel = stated || panel.youngs_per_k != 0 ? &panel : nullptr;
    // The safe range of every focus (FocusMetrics::gain_range, the verdict's
    // rule at any gain) with the threshold it was judged at and where it looked:
    // the whole area when every focus's was measured (through H), else the
    // other foci only (the forward path), the scope the verdict itself had (a
    // focus whose whole area was measured as well has the narrower range:
    // still true of the foci).
    haptic_range_spec range{};
    range.threshold_m = in.calibration.threshold_m;
    range.scope = whole_area ? HAPTIC_RANGE_WHOLE_AREA : HAPTIC_RANGE_FOCI_ONLY;
    range.focus = ranges.data();
    spec.range = &range;
    haptic_table_error err{};
    if (haptic_table_write(path.c_str(), &spec, &err) != 0)
        throw std::runtime_error(path + ": " + err.message);
}

} // namespace calib::pipeline
