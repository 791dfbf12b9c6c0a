#include "scene/measurement_plan.h"

#include "scene/toml_fields.h"

#include "engine/plate_operator.h"
#include "io/format.h"
#include "pipeline/signal/pulse.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>

namespace calib::scene {

namespace {

constexpr double lead_in_s = 0.25;
constexpr double min_sweep_s = 1, max_sweep_s = 30;
constexpr double gap_factor = 1.25, gap_extra_s = 0.05;
constexpr double distortion_db = 20; // the second harmonic's response below the linear one, assumed

std::string toml_string(const std::string &s)
{
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\')
            out += '\\';
        if (static_cast<unsigned char>(c) < 0x20) {
            out += io::fmt("\\u%04x", unsigned(c));
            continue;
        }
        out += c;
    }
    return out + "\"";
}

void check_range(const char *option, double v, double lo, double hi, bool hi_open)
{
    if (!(v >= lo && (hi_open ? v < hi : v <= hi)))
        throw std::invalid_argument(std::string(option) + ": must lie in [" + format_number(lo) + ", " +
                                    format_number(hi) + (hi_open ? ")" : "]") + ", got " + format_number(v));
}

} // namespace

MeasurementPlan plan_measurement(const Scene &s, const std::vector<pipeline::Point> &exciters, const PlanOptions &o)
{
    if (!s.exciters)
        throw SceneError(s.file + ": exciters: missing section (the plan drives each exciter in turn)");
    if (!s.pulse)
        throw SceneError(s.file + ": pulse: missing section (the sweep covers the pulse's band)");
    if (!s.plate.loss)
        throw SceneError(s.file + ": plate.loss: missing (the silence after each sweep waits for the plate's decay, "
                                  "which the loss law gives)");
    double rate = 0;
    if (o.rate_hz)
        rate = *o.rate_hz;
    else if (s.calibration)
        rate = s.calibration->output_rate_hz;
    else
        throw SceneError(s.file + ": calibration.output_rate_hz: missing (the board's rate; or give --rate)");
    if (!(rate >= 8000 && rate <= 768000 && rate == std::round(rate)))
        throw std::invalid_argument((o.rate_hz ? std::string("--rate") : s.file + ": calibration.output_rate_hz") +
                                    ": a whole number of Hz in [8000, 768000] is needed, got " + format_number(rate));
    check_range("--level-dbfs", o.level_dbfs, -60, 0, true);
    check_range("--snr-db", o.snr_db, 20, 120, false);
    check_range("--recording-snr-db", o.recording_snr_db, 0, 120, false);
    const std::string from = o.positions_from.empty() ? s.file + ": exciters.positions_m" : o.positions_from;
    if (exciters.size() != s.exciters->count)
        throw std::invalid_argument(from + ": " + std::to_string(exciters.size()) + " exciter positions for the " +
                                    std::to_string(s.exciters->count) + " exciters of " + s.file);
    for (std::size_t e = 0; e < exciters.size(); e++) {
        const pipeline::Point &p = exciters[e];
        if (!(p.x_m >= 0 && p.x_m <= s.plate.size_x_m && p.y_m >= 0 && p.y_m <= s.plate.size_y_m))
            throw std::invalid_argument(from + ": exciter " + std::to_string(e) + " at (" + format_number(p.x_m) +
                                        ", " + format_number(p.y_m) + ") m is off the " +
                                        format_number(s.plate.size_x_m) + " x " + format_number(s.plate.size_y_m) +
                                        " m plate");
    }

    MeasurementPlan plan;
    plan.exciters = exciters;
    plan.force_full_scale_n = s.exciters->force_full_scale_n;

    // The band.
    const pipeline::PulseSpec &pulse = *s.pulse;
    plan.pulse_hi_hz = pipeline::pulse_max_frequency_hz(pulse);
    plan.pulse_lo_hz = std::max(2 * pulse.centre_hz - plan.pulse_hi_hz, 0.25 * pulse.centre_hz);
    const double f1 = 0.5 * plan.pulse_lo_hz, f2 = std::min(1.5 * plan.pulse_hi_hz, 0.45 * rate);
    if (f2 < std::cbrt(2.0) * plan.pulse_hi_hz)
        throw std::invalid_argument((o.rate_hz ? std::string("--rate") : s.file + ": calibration.output_rate_hz") +
                                    ": " + format_number(rate) + " Hz cannot carry a sweep a third of an octave past " +
                                    "the pulse's band top " + io::fmt("%.0f Hz", plan.pulse_hi_hz) +
                                    " (the sweep stays below 0.45 of the rate)");

    // The plate's decay from the loss law (amplitude decay rates, 1/s).
    const double kappa = s.plate.material.kappa(s.plate.thickness_m);
    engine::Loss loss;
    try {
        const LossSpec &l = *s.plate.loss;
        loss = engine::loss_from_t60(kappa, l.f1_hz, l.t60_1_s, l.f2_hz, l.t60_2_s);
    } catch (const std::invalid_argument &e) {
        throw SceneError(s.file + ": plate.loss: " + e.what());
    }
    const auto decay_s = [&](double f_hz, double db) {
        const double sigma = loss.decay_rate_1_s(2 * std::numbers::pi * f_hz, kappa);
        if (!(sigma > 0))
            throw SceneError(s.file + ": plate.loss: no decay at " + io::fmt("%.0f Hz", f_hz) +
                             " (the silence after a sweep would never end)");
        return db / 20 * std::numbers::ln10 / sigma;
    };
    plan.decay_f1_s = decay_s(f1, o.snr_db);
    plan.gap_s = gap_factor * plan.decay_f1_s + gap_extra_s;
    plan.lead_s = lead_in_s;

    // The length.
    const double octaves = std::log2(f2 / f1);
    plan.sweep_s_snr = pipeline::sweep_s_for_snr(o.snr_db, o.recording_snr_db, f2 - f1);
    plan.sweep_s_distortion = octaves * decay_s(2 * f1, std::max(o.snr_db - distortion_db, 0.0));
    double T = std::max(plan.sweep_s_snr, plan.sweep_s_distortion);
    plan.length_rule =
        plan.sweep_s_snr >= plan.sweep_s_distortion
            ? io::fmt("the SNR rule (%.0f dB from %.0f dB over %.0f Hz)", o.snr_db, o.recording_snr_db, f2 - f1)
            : io::fmt("the second harmonic's decay (%.0f dB at %.0f Hz before t = 0)",
                      std::max(o.snr_db - distortion_db, 0.0), 2 * f1);
    if (T < min_sweep_s) {
        T = min_sweep_s;
        plan.length_rule = "the 1 s minimum";
    } else if (T > max_sweep_s) {
        T = max_sweep_s;
        plan.length_rule = "the 30 s maximum";
    }

    pipeline::SweepSpec &sw = plan.sweep;
    sw.f1_hz = f1;
    sw.f2_hz = f2;
    sw.rate_hz = rate;
    // Lengths in whole 10 ms (whole frames at 44.1 and 48 kHz alike), rounded up.
    const auto centis = [](double t_s) { return std::ceil(t_s * 100 - 1e-9) / 100; };
    const auto sweep_frames = static_cast<std::size_t>(std::llround(centis(T) * rate));
    sw.duration_s = double(sweep_frames) / rate;
    sw.amplitude = std::pow(10.0, o.level_dbfs / 20);
    pipeline::check_sweep(sw);
    plan.predicted_snr_db = pipeline::deconvolved_snr_db(o.recording_snr_db, sw.duration_s, f2 - f1);
    if (plan.length_rule == "the 30 s maximum")
        plan.length_rule += io::fmt(": the deconvolved SNR reaches only %.0f dB", plan.predicted_snr_db);

    plan.layout =
        pipeline::plan_layout(exciters.size(), static_cast<std::size_t>(std::llround(lead_in_s * rate)), sweep_frames,
                              static_cast<std::size_t>(std::llround(centis(plan.gap_s) * rate)));
    plan.gap_s = double(plan.layout.gap_frames) / rate;
    if (double(plan.layout.total_frames) * double(exciters.size()) * 2 > 2e9)
        throw std::invalid_argument(s.file + ": " +
                                    io::fmt("the plan would last %.0f s on %zu channels: over 2 GB of WAV",
                                            double(plan.layout.total_frames) / rate, exciters.size()));
    return plan;
}

std::vector<int16_t> plan_pcm16(const MeasurementPlan &plan)
{
    return pipeline::plan_samples(plan.layout, pipeline::quantize_pcm16(pipeline::exponential_sweep(plan.sweep)));
}

std::string measurements_toml(const MeasurementPlan &plan, const std::string &plan_file, const std::string &scene_path,
                              const std::string &scene_hash, const std::string &command)
{
    const pipeline::SweepSpec &sw = plan.sweep;
    std::ostringstream o;
    o << "# The bench measurement (docs/bench.md, \"The plan and measurements.toml\").\n"
      << "# Scene:   " << scene_path << " (" << scene_hash << ")\n"
      << "# Command: " << command << "\n"
      << "# Plan:    " << plan_file << ": " << plan.exciters.size() << " channels (channel c drives exciter c), "
      << io::fmt("%.0f Hz PCM_16;\n", sw.rate_hz)
      << io::fmt("#          each exciter alone in turn: an exponential sweep %.1f to %.1f Hz", sw.f1_hz, sw.f2_hz)
      << io::fmt(" of %.3f s at %.1f dBFS,", sw.duration_s, 20 * std::log10(sw.amplitude))
      << io::fmt(" then %.3f s of silence; %.2f s in all.\n", plan.gap_s, plan.total_s())
      << "# To do: play the plan on the board and record every sensor at once, sample-synchronous\n"
      << "#   (sample 0 of the recording is sample 0 of the plan):\n"
      << "#     hapticd --board BOARD --measure " << plan_file << " --capture rec.wav\n"
      << "#   name the recording under [recording] and add one [[sensor]] table per recorded sensor\n"
      << "#   (below), then: calibgen fit SCENE measurements.toml -o fitted.toml --report DIR\n"
      << "scene = " << toml_string(scene_path) << "\n\n"
      << "[excitation]\n"
      << "file = " << toml_string(plan_file) << "  # relative to this file's directory\n"
      << "rate_hz = " << format_number(sw.rate_hz) << "\n"
      << "sweep_hz = [" << format_number(sw.f1_hz) << ", " << format_number(sw.f2_hz) << "]  # informative\n"
      << "sweep_s = " << format_number(sw.duration_s) << "\n"
      << "gap_s = " << format_number(plan.gap_s) << "\n"
      << "start_frames = [";
    for (std::size_t c = 0; c < plan.layout.start_frames.size(); c++)
        o << (c ? ", " : "") << plan.layout.start_frames[c];
    o << "]  # where each exciter's sweep starts (channel c -> exciter c)\n\n"
      << "[exciters]\n"
      << "positions_m = [";
    for (std::size_t e = 0; e < plan.exciters.size(); e++)
        o << (e ? ", " : "") << "[" << format_number(plan.exciters[e].x_m) << ", "
          << format_number(plan.exciters[e].y_m) << "]";
    o << "]  # nominal positions, as glued\n"
      << "force_full_scale_n = " << format_number(plan.force_full_scale_n) << "\n\n"
      << "[recording]\n"
      << "file = \"rec.wav\"  # sample 0 is the plan's sample 0; relative to this file's directory\n\n"
      << "# One [[sensor]] table per recorded sensor, for instance:\n"
      << "# [[sensor]]\n"
      << "# position_m = [0.25, 0.40]     # on the plate, metres from its lower-left corner\n"
      << "# channel = 0                   # of the recording, from 0\n"
      << "# quantity = \"acceleration\"     # \"displacement\", \"velocity\" or \"acceleration\"\n"
      << "# units_per_count = 0.02        # SI units per full-scale-normalised sample; omit if unknown\n";
    return o.str();
}

} // namespace calib::scene
