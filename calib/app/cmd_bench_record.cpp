// `calibgen bench-record PANEL.toml MEASUREMENTS.toml [--noise-db D] [--seed N]`:
// the recording a bench would make on a panel described by a scene of its own
// (pipeline/bench/bench_synth.h): the plan of MEASUREMENTS.toml played
// through PANEL's fixed exciters (their positions and force gains), each
// sensor's quantity at its channel, white noise D dB below the response;
// written to the recording file MEASUREMENTS.toml names. A dry run of the
// bench step, and its worked example (docs/bench.md).
#include "app/commands.h"
#include "app/progress.h"
#include "io/atomic_file.h"
#include "io/format.h"
#include "io/read_file.h"
#include "pipeline/bench/bench_synth.h"
#include "scene/calibration_input.h"
#include "scene/measurements.h"
#include "scene/wav_file.h"

#include <algorithm>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::app {

namespace {

using io::fmt;

struct BenchRecordArgs {
    std::string panel, measurements;
    double noise_db = -30;
    uint64_t seed = 1;
    bool quiet = false;
};

int run_bench_record(const BenchRecordArgs &a)
{
    const std::optional<std::string> bytes = io::read_file(a.panel);
    if (!bytes)
        throw std::runtime_error(a.panel + ": cannot open scene file");
    const scene::Scene s = scene::parse_scene(*bytes, a.panel);
    if (!s.calibration_sections() || s.exciters->placement != pipeline::PlacementMode::fixed)
        throw std::runtime_error(a.panel + ": exciters: the panel needs placement = \"fixed\" (where its exciters "
                                           "are glued) and the calibration sections");
    const pipeline::CalibrationInput in = scene::calibration_input(s, scene::build_plate(s), *bytes);
    const scene::Measurements m = scene::load_measurements(a.measurements, s, scene::RecordingRead::skip);
    std::vector<std::vector<double>> plan;
    for (std::size_t c = 0; c < m.plan.channels; c++)
        plan.push_back(m.plan.channel(c, 0, m.plan.frames));
    std::vector<pipeline::BenchSensor> sensors;
    std::vector<std::optional<double>> units;
    std::size_t channels = 0;
    for (const scene::MeasuredSensor &sensor : m.sensors) {
        sensors.push_back({sensor.at, sensor.quantity});
        units.push_back(sensor.units_per_count);
        channels = std::max(channels, sensor.channel + 1);
    }
    if (sensors.empty())
        throw std::runtime_error(a.measurements + ": sensor: no [[sensor]] to record");
    Progress progress(a.quiet);
    const pipeline::SyntheticRecording r = pipeline::synthesize_recording(
        in, sensors, units, plan, m.rate_hz, m.gap_s, m.sweep_f2_hz, a.noise_db, a.seed, progress.callback());
    std::vector<float> frames(m.plan.frames * channels, 0.0f);
    double peak = 0;
    for (std::size_t k = 0; k < m.sensors.size(); k++)
        for (std::size_t n = 0; n < m.plan.frames; n++) {
            frames[n * channels + m.sensors[k].channel] = static_cast<float>(r.channels[k][n]);
            peak = std::max(peak, std::abs(r.channels[k][n]));
        }
    if (peak >= 1)
        throw std::runtime_error(a.measurements +
                                 ": sensor: units_per_count too small: the recording would clip "
                                 "(peak " +
                                 fmt("%.2f", peak) + " of full scale)");
    io::write_file_atomic(m.recording_path, scene::wav_float_bytes(frames, channels, static_cast<unsigned>(m.rate_hz)));
    std::printf("bench-record: %s on %s: %zu sensors, %zu frames, noise %.0f dB below the response; peak %.2f of "
                "full scale\n",
                a.measurements.c_str(), a.panel.c_str(), m.sensors.size(), m.plan.frames, -a.noise_db, peak);
    for (std::size_t k = 0; k < m.sensors.size(); k++)
        std::printf("  sensor %zu (channel %zu): units_per_count %.6g%s\n", k + 1, m.sensors[k].channel,
                    r.units_per_count[k], m.sensors[k].units_per_count ? "" : " (chosen: the file did not say)");
    std::printf("  wrote %s\n", m.recording_path.c_str());
    return 0;
}

} // namespace

void register_bench_record(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<BenchRecordArgs>();
    CLI::App *cmd = app.add_subcommand(
        "bench-record", "Simulate the bench's recording on a panel described by a scene (a dry run of the bench step)");
    cmd->add_option("panel", a->panel, "The panel's scene (fixed exciters, force gains)")->required();
    cmd->add_option("measurements", a->measurements, "measurements.toml with its [[sensor]] entries")->required();
    cmd->add_option("--noise-db", a->noise_db, "Noise RMS relative to the response while an exciter sweeps (dB)")
        ->check(CLI::Range(-200.0, 0.0));
    cmd->add_option("--seed", a->seed, "Seed of the noise");
    cmd->add_flag("-q,--quiet", a->quiet, "No progress lines");
    cmd->callback([a, &exit_code] { exit_code = run_bench_record(*a); });
}

} // namespace calib::app
