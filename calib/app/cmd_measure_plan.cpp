// `calibgen measure-plan SCENE -o DIR [--table T.htab] [--rate HZ]
// [--level-dbfs D] [--snr-db S] [--recording-snr-db R]`: the bench's plan
// (docs/bench.md, "The plan and measurements.toml"): DIR/plan.wav, one
// exponential sweep per exciter in turn with silence for the plate's decay,
// and DIR/measurements.toml for the lab to fill in. The choices are
// scene/measurement_plan.h's; this prints them and writes the two files.
#include "app/commands.h"
#include "io/atomic_file.h"
#include "io/format.h"
#include "io/read_file.h"
#include "pipeline/data/input.h"
#include "scene/measurement_plan.h"
#include "scene/scene.h"
#include "scene/toml_fields.h"
#include "scene/wav_file.h"

#include <haptic_table.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::app {

namespace {

using io::fmt;

struct MeasurePlanArgs {
    std::string scene, dir, table;
    std::optional<double> rate_hz;
    double level_dbfs = -6, snr_db = 60, recording_snr_db = 30;
};

constexpr const char *plan_file = "plan.wav";
constexpr const char *toml_file = "measurements.toml";

// The exciters' positions: the table's (where a calibration put them) or the
// scene's fixed placement.
std::vector<pipeline::Point> exciter_positions(const MeasurePlanArgs &a, const scene::Scene &s,
                                               const std::string &scene_hash)
{
    std::vector<pipeline::Point> at;
    if (!a.table.empty()) {
        haptic_table t{};
        haptic_table_error err{};
        if (haptic_table_open(a.table.c_str(), &t, &err) != 0)
            throw std::runtime_error(a.table + ": " + err.message);
        std::unique_ptr<haptic_table, void (*)(haptic_table *)> guard(&t, haptic_table_close);
        if (t.channel_count != s.exciters->count)
            throw std::runtime_error(a.table + ": " + std::to_string(t.channel_count) + " channels but " + a.scene +
                                     " has " + std::to_string(s.exciters->count) + " exciters");
        at.resize(t.channel_count);
        for (uint32_t c = 0; c < t.channel_count; c++)
            haptic_table_channel_position(&t, c, &at[c].x_m, &at[c].y_m);
        haptic_provenance prov{};
        haptic_table_provenance(&t, &prov);
        if (prov.scene_hash[0] != '\0' && scene_hash != prov.scene_hash)
            std::fprintf(stderr,
                         "note: %s was calibrated from a scene of hash %s, %s is %s (positions from the table)\n",
                         a.table.c_str(), prov.scene_hash, a.scene.c_str(), scene_hash.c_str());
        return at;
    }
    if (s.exciters->placement != pipeline::PlacementMode::fixed)
        throw std::runtime_error(
            a.scene + ": exciters.placement: \"" +
            (s.exciters->placement == pipeline::PlacementMode::random ? "random" : "regular") +
            "\": where the exciters are glued is the calibration's choice: give --table TABLE.htab (it stores "
            "their positions) or placement = \"fixed\" with positions_m");
    return s.exciters->positions;
}

std::string command_line(const MeasurePlanArgs &a)
{
    std::string c = "calibgen measure-plan " + a.scene + " -o " + a.dir;
    if (!a.table.empty())
        c += " --table " + a.table;
    if (a.rate_hz)
        c += " --rate " + scene::format_number(*a.rate_hz);
    c += " --level-dbfs " + scene::format_number(a.level_dbfs) + " --snr-db " + scene::format_number(a.snr_db) +
         " --recording-snr-db " + scene::format_number(a.recording_snr_db);
    return c;
}

int run_measure_plan(const MeasurePlanArgs &a)
{
    const std::optional<std::string> bytes = io::read_file(a.scene);
    if (!bytes)
        throw std::runtime_error(a.scene + ": cannot open scene file");
    const scene::Scene s = scene::parse_scene(*bytes, a.scene);
    if (!s.exciters)
        throw scene::SceneError(a.scene + ": exciters: missing section (the plan drives each exciter in turn)");
    const std::string hash = pipeline::scene_hash(*bytes);
    const std::vector<pipeline::Point> exciters = exciter_positions(a, s, hash);
    scene::PlanOptions o;
    o.rate_hz = a.rate_hz;
    o.level_dbfs = a.level_dbfs;
    o.snr_db = a.snr_db;
    o.recording_snr_db = a.recording_snr_db;
    o.positions_from = a.table; // empty: the scene's positions_m
    const scene::MeasurementPlan plan = scene::plan_measurement(s, exciters, o);
    // Everything in memory first: a refusal above leaves nothing on disk.
    const std::string wav = scene::wav_pcm16_bytes(scene::plan_pcm16(plan), plan.exciters.size(),
                                                   static_cast<unsigned>(plan.sweep.rate_hz));
    const std::string toml = scene::measurements_toml(plan, plan_file, a.scene, hash, command_line(a));
    const std::filesystem::path dir(a.dir);
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec)
        throw std::runtime_error(a.dir + ": cannot create the directory: " + ec.message());
    const std::string wav_path = (dir / plan_file).string(), toml_path = (dir / toml_file).string();
    io::write_file_atomic(wav_path, wav);
    try {
        io::write_file_atomic(toml_path, toml);
    } catch (...) {
        std::filesystem::remove(wav_path, ec);
        throw;
    }

    const pipeline::SweepSpec &sw = plan.sweep;
    std::printf("measure-plan: %s, %zu exciters (positions from %s)\n", s.name.c_str(), plan.exciters.size(),
                a.table.empty() ? "the scene's fixed placement" : a.table.c_str());
    std::printf("  band     %.1f to %.1f Hz: the pulse's %.0f to %.0f Hz, x0.5 below and x1.5 above (at most 0.45 "
                "of %.0f Hz)\n",
                sw.f1_hz, sw.f2_hz, plan.pulse_lo_hz, plan.pulse_hi_hz, sw.rate_hz);
    std::printf("  sweep    %.3f s per exciter, set by %s\n", sw.duration_s, plan.length_rule.c_str());
    std::printf("           (SNR rule %.3f s, 2nd-harmonic rule %.3f s); predicted deconvolved SNR %.0f dB; the 2nd "
                "harmonic lands %.3f s before t = 0\n",
                plan.sweep_s_snr, plan.sweep_s_distortion, plan.predicted_snr_db, pipeline::harmonic_lead_s(sw, 2));
    std::printf("  gap      %.3f s of silence after each sweep (the loss law brings %.1f Hz down %.0f dB in %.3f s; "
                "x1.25 + 50 ms)\n",
                plan.gap_s, sw.f1_hz, a.snr_db, plan.decay_f1_s);
    std::printf("  level    %.1f dBFS peak, PCM_16 at %.0f Hz; lead-in %.2f s of silence\n", a.level_dbfs, sw.rate_hz,
                plan.lead_s);
    std::printf("  total    %.2f s (%zu frames)\n", plan.total_s(), plan.layout.total_frames);
    std::printf("wrote %s and %s\n", wav_path.c_str(), toml_path.c_str());
    return 0;
}

} // namespace

void register_measure_plan(CLI::App &app, int &exit_code)
{
    auto a = std::make_shared<MeasurePlanArgs>();
    CLI::App *cmd = app.add_subcommand(
        "measure-plan", "Write the bench's plan (an exponential sweep per exciter in turn, plan.wav) and "
                        "measurements.toml to fill in (docs/bench.md)");
    cmd->add_option("scene", a->scene, "Scene file (TOML)")->required();
    cmd->add_option("-o,--output", a->dir, "Directory for plan.wav and measurements.toml")->required();
    cmd->add_option("--table", a->table, "Table (.htab) whose exciter positions to use (a random-placement scene)");
    cmd->add_option("--rate", a->rate_hz, "Sample rate (Hz); default: the scene's calibration.output_rate_hz");
    cmd->add_option("--level-dbfs", a->level_dbfs, "Peak level of the sweep (dB of full scale, default -6)");
    cmd->add_option("--snr-db", a->snr_db,
                    "Wanted SNR of the deconvolved responses, and the decay the silence waits for (default 60)");
    cmd->add_option("--recording-snr-db", a->recording_snr_db, "Expected SNR of the raw recording (default 30)");
    cmd->callback([a, &exit_code] { exit_code = run_measure_plan(*a); });
}

} // namespace calib::app
