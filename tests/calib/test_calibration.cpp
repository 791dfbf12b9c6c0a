// The calibration pipeline end to end on a small, fast scene, the scene's
// calibration sections (every key, every error path), the refusal of
// impossible scenes, and the Fig. 4 placement against the regular pattern.
#include "engine/simulation.h"
#include "physics/dispersion.h"
#include "pipeline/calibrate.h"
#include "pipeline/signal/resample.h"
#include "pipeline/table_writer.h"
#include "pipeline/verification/verification.h"
#include "scene/calibration_input.h"
#include "scene/toml_fields.h"

#include <haptic_table.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "scene_text.h"

using namespace calib;

namespace {

using scene_text::replace;

// The demonstrator scaled down (half the size, four times the frequency, a
// quarter of the time): 2 x 2 foci, the whole pipeline in about two seconds.
const std::string small_scene = scene_text::load("small.toml");

pipeline::CalibrationInput input_of(const std::string &text, const std::string &name = "small.toml")
{
    return scene::calibration_input(text, name);
}

std::string error_of(const std::string &text)
{
    try {
        input_of(text);
    } catch (const scene::SceneError &e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(CalibrationScene, EveryKeyIsRead)
{
    scene::Scene s = scene::parse_scene(small_scene, "small.toml");
    ASSERT_TRUE(s.calibration_sections());
    EXPECT_EQ(s.name, "small");
    EXPECT_DOUBLE_EQ(s.active_area->area.x1_m, 0.30);
    EXPECT_DOUBLE_EQ(s.active_area->frame_margin_m, 0.01);
    EXPECT_DOUBLE_EQ(s.active_area->clearance_m, 0.003);
    EXPECT_EQ(s.exciters->count, 8u);
    EXPECT_EQ(s.exciters->seed, 3u);
    EXPECT_EQ(s.exciters->restarts, 2u);
    EXPECT_EQ(s.exciters->iterations, 300u);
    EXPECT_DOUBLE_EQ(s.exciters->force_full_scale_n, 0.5);
    EXPECT_DOUBLE_EQ(s.exciters->min_spacing_m, 0.03);
    ASSERT_EQ(s.foci->points.size(), 4u);
    // Grid foci: cell centres of the active area, row by row from the lower left.
    EXPECT_EQ(s.foci->points[1].id, 2u);
    EXPECT_DOUBLE_EQ(s.foci->points[1].at.x_m, 0.05 + 0.25 * 0.75);
    EXPECT_DOUBLE_EQ(s.foci->points[1].at.y_m, 0.05 + 0.25 * 0.25);
    EXPECT_DOUBLE_EQ(s.pulse->centre_hz, 1200);
    EXPECT_DOUBLE_EQ(s.calibration->window_s, 0.05);
    EXPECT_DOUBLE_EQ(s.calibration->verify_tail_s, 0.025);
    // f_max comes from the pulse's band when [simulation] does not give it.
    EXPECT_DOUBLE_EQ(s.simulation.f_max_hz, pipeline::pulse_max_frequency_hz(*s.pulse));

    scene::Scene fixed = scene::parse_scene(
        replace(replace(small_scene, "placement = \"random\"", "placement = \"fixed\"\ncontrast_window = \"focus\""),
                "count = 8\n", "positions_m = [[0.02, 0.02], [0.28, 0.02], [0.15, 0.28]]\n") +
            "",
        "f.toml");
    EXPECT_EQ(fixed.exciters->count, 3u);
    EXPECT_TRUE(fixed.exciters->contrast_at_focus_instant);
    EXPECT_EQ(fixed.name, "small");
    EXPECT_EQ(scene::parse_scene(replace(small_scene, "name = \"small\"\n", ""), "dir/x.toml").name, "x");
    scene::Scene pts = scene::parse_scene(
        replace(small_scene, "grid = [2, 2]", "points_m = [[0.1, 0.1], [0.2, 0.2]]\nids = [7, 9]"), "p.toml");
    ASSERT_EQ(pts.foci->points.size(), 2u);
    EXPECT_EQ(pts.foci->points[1].id, 9u);
    EXPECT_DOUBLE_EQ(pts.foci->points[1].at.x_m, 0.2);
}

TEST(CalibrationScene, EveryBadValueNamesItsKey)
{
    const struct {
        const char *from, *to, *message;
    } cases[] = {
        {"rect_m = [0.05, 0.05, 0.30, 0.30]", "rect_m = [0.30, 0.05, 0.05, 0.30]",
         "small.toml: active_area.rect_m: needs x0 < x1 and y0 < y1"},
        {"frame_margin_m = 0.01", "frame_margin_m = -1",
         "small.toml: active_area.frame_margin_m: must be >= 0, got -1"},
        {"count = 8", "count = 40", "small.toml: exciters.count: must lie in [1, 32], got 40"},
        {"placement = \"random\"", "placement = \"spiral\"",
         "small.toml: exciters.placement: unknown value \"spiral\" (known: random, regular, fixed)"},
        {"placement = \"random\"", "placement = \"fixed\"",
         "small.toml: exciters.positions_m: missing (required with placement = \"fixed\"): [[x, y], ...] in metres"},
        {"seed = 3", "seed = -3", "small.toml: exciters.seed: must be >= 0, got -3"},
        {"force_full_scale_n = 0.5", "force_full_scale_n = 0",
         "small.toml: exciters.force_full_scale_n: must be > 0, got 0"},
        {"restarts = 2", "restarts = 0", "small.toml: exciters.restarts: must lie in [1, 1000], got 0"},
        {"grid = [2, 2]", "grid = [2.5, 2]", "small.toml: foci.grid: needs whole numbers >= 1 and at most 1024 foci"},
        {"grid = [2, 2]", "grid = [2, 2]\npoints_m = [[0.1, 0.1]]",
         "small.toml: foci.points_m: give exactly one of grid = [nx, ny], pitch_m = p or points_m = [[x, y], ...]"},
        {"grid = [2, 2]", "points_m = [[0.1, 0.1], [0.2]]",
         "small.toml: foci.points_m: entry 1 must be an [x, y] pair in metres"},
        {"grid = [2, 2]", "points_m = [[0.1, 0.1], [0.2, 0.2]]\nids = [1, 1]",
         "small.toml: foci.ids: must be distinct integers in [0, 4294967295]"},
        {"shape = \"hann_burst\"", "shape = \"square\"",
         "small.toml: pulse.shape: unknown pulse shape 'square' (known: hann_burst, gaussian_burst, ricker)"},
        {"centre_hz = 1200", "", "small.toml: pulse.centre_hz: missing (required)"},
        {"cycles = 2", "cycles = 0.1", "small.toml: pulse.cycles: must lie in [0.5, 100], got 0.1"},
        {"truncate_fraction = 0.3", "truncate_fraction = 1.5",
         "small.toml: calibration.truncate_fraction: must lie in (0, 1], got 1.5"},
        {"output_rate_hz = 48000", "output_rate_hz = 44100.5",
         "small.toml: calibration.output_rate_hz: must be a whole number of Hz in [8000, 384000], got 44100.5"},
        {"threshold_m = 5e-6", "threshold_m = 5e-6\nsample_format = \"f32\"",
         "small.toml: calibration.sample_format: unknown format \"f32\" (known: s16)"},
        {"threshold_m = 5e-6", "threshold_m = 5e-6\ndither = 1",
         "small.toml: calibration.dither: must be true or false"},
        {"threshold_m = 5e-6", "threshold_m = 5e-6\naccuracy = 2",
         "small.toml: calibration.accuracy: is a relative error, must lie in (0, 1), got 2"},
        {"threshold_m = 5e-6", "threshold_m = 5e-6\nwindow = 1", "small.toml: calibration.window: unknown key"},
    };
    for (const auto &c : cases) {
        const std::string err = error_of(replace(small_scene, c.from, c.to));
        EXPECT_EQ(err.substr(0, std::string(c.message).size()), c.message) << c.to;
        EXPECT_EQ(err.find('\n'), std::string::npos);
    }
}

TEST(CalibrationScene, ImpossibleScenesAreRefusedBeforeSimulating)
{
    auto refusal = [](const std::string &text) {
        try {
            pipeline::check_feasible(input_of(text));
        } catch (const std::invalid_argument &e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_EQ(refusal(small_scene), "");
    EXPECT_NE(refusal(replace(small_scene, "window_s = 0.05", "window_s = 0.001"))
                  .find("calibration.window_s: 0.001 s is shorter than one crossing of the plate"),
              std::string::npos);
    EXPECT_NE(refusal(replace(small_scene, "grid = [2, 2]", "points_m = [[0.1, 0.1], [0.36, 0.1]]"))
                  .find("foci: focus 2 at (0.36, 0.1) m is not inside the plate"),
              std::string::npos);
    EXPECT_NE(refusal(replace(small_scene, "min_spacing_m = 0.03", "min_spacing_m = 0.2"))
                  .find("exciters.count: the border band"),
              std::string::npos);
}

TEST(Calibration, EndToEndEveryFocusForms)
{
    pipeline::CalibrationInput in = input_of(small_scene);
    // The contrast model predicts the seed's time reversal: equal gains
    // (the minimax gains are test_exciter_gains's).
    in.calibration.exciter_gains = pipeline::ExciterGainsMode::equal;
    pipeline::CalibrationResult r = pipeline::calibrate(in);
    ASSERT_EQ(r.exciters.size(), 8u);
    // Never in the active area or the margins.
    for (const pipeline::Point &p : r.exciters) {
        EXPECT_FALSE(in.active.area.contains(p, in.active.clearance_m));
        EXPECT_GE(std::min({p.x_m, p.y_m, 0.35 - p.x_m, 0.35 - p.y_m}), 0.01 - 1e-12);
    }
    const double lambda_half = physics::kirchhoff_wavelength_m(in.plate->kappa(), 1200) / 2;
    // Reciprocity: the contrast predicted from the emitted-at-the-focus
    // simulations equals what driving the exciters produces (up to resampling
    // and 16-bit quantization).
    double worst = 1e9;
    for (const pipeline::FocusMetrics &m : r.verification.foci)
        worst = std::min(worst, m.other_foci_contrast_db);
    EXPECT_NEAR(r.placement.chosen_contrast_db, worst, 0.5);
    for (size_t f = 0; f < 4; f++) {
        const pipeline::FocusMetrics &m = r.verification.foci[f];
        SCOPED_TRACE("focus " + std::to_string(m.id));
        // Played at the level that gives the target amplitude (dither: 0.5 %).
        EXPECT_NEAR(m.peak_m, 10e-6, 0.05e-6);
        // The seed's criterion: the focus crosses the threshold, the other foci never do.
        EXPECT_TRUE(m.crosses_threshold);
        EXPECT_TRUE(m.others_below_threshold) << m.max_other_foci_m;
        EXPECT_GT(m.field_contrast_db, 0.0); // the focus is the largest displacement on the plate
        EXPECT_GT(m.spot_diameter_m, 0.5 * lambda_half);
        EXPECT_LT(m.spot_diameter_m, 2.5 * lambda_half);
        // It forms at the instant time reversal predicts (within one pulse length).
        EXPECT_NEAR(m.lead_time_s, r.signals[f].focus_delay_s, 2.0 / 1200);
    }
    // The table holds exactly what was verified: verifying it again gives the same numbers.
    const std::string path = (std::filesystem::temp_directory_path() / "calib-e2e.htab").string();
    pipeline::write_table(path, in, r);
    haptic_table t{};
    haptic_table_error err{};
    ASSERT_EQ(haptic_table_open(path.c_str(), &t, &err), 0) << err.message;
    EXPECT_EQ(t.channel_count, 8u);
    EXPECT_EQ(t.focus_count, 4u);
    std::vector<std::vector<int16_t>> signals;
    for (uint32_t f = 0; f < 4; f++) {
        const int16_t *s = haptic_table_signal(&t, f);
        signals.emplace_back(s, s + size_t(t.samples_per_signal) * t.channel_count);
        haptic_focus_info fi;
        haptic_table_focus(&t, f, &fi);
        EXPECT_DOUBLE_EQ(fi.scale_m, r.verification.foci[f].peak_m);
        // The lead time a device states is the verified focal peak's instant,
        // which time reversal puts at the end of the kept window.
        EXPECT_DOUBLE_EQ(fi.lead_time_s, r.verification.foci[f].lead_time_s);
        EXPECT_NEAR(fi.lead_time_s, r.signals[f].focus_delay_s, 2.0 / 1200);
    }
    EXPECT_DOUBLE_EQ(haptic_table_force_full_scale_n(&t), in.exciters.force_full_scale_n);
    // The plate the drives are for (format 1.2): 23 C by default, the material's dE/E/dT.
    haptic_panel panel{};
    ASSERT_EQ(haptic_table_panel(&t, &panel), 0);
    EXPECT_EQ(panel.temperature_c, 23.0);
    EXPECT_EQ(panel.youngs_per_k, in.plate->params().material.youngs_per_kelvin);
    EXPECT_NE(panel.youngs_per_k, 0.0);
    // An independent check of the level: the plate simulated directly (no
    // transfer matrix, no convolution) under the table's counts for focus 0,
    // read as the table format defines them (force_full_scale_n at 32767).
    {
        engine::Simulation sim(in.plate, pipeline::single_core_options(in));
        const size_t frames = t.samples_per_signal, C = t.channel_count;
        const int16_t *s0 = haptic_table_signal(&t, 0);
        for (size_t c = 0; c < C; c++) {
            std::vector<double> x(frames);
            for (size_t n = 0; n < frames; n++)
                x[n] = s0[n * C + c] / 32767.0 * haptic_table_force_full_scale_n(&t);
            const size_t src = sim.add_source(r.exciters[c].x_m, r.exciters[c].y_m);
            sim.set_source_signal(src, pipeline::resample(x, t.sample_rate_hz, 1.0 / sim.time_step_s()));
        }
        const pipeline::Point at = in.foci.points[0].at;
        sim.add_receiver(at.x_m, at.y_m);
        sim.run(sim.steps_for(static_cast<double>(frames) / t.sample_rate_hz + 0.01));
        double peak = 0;
        for (double w : sim.traces()[0])
            peak = std::max(peak, std::abs(w));
        EXPECT_NEAR(peak / 10e-6, 1.0, 0.005) << "directly simulated focal peak " << peak << " m";
    }
    pipeline::Verification again = pipeline::verify_signals(in, r.exciters, signals, t.sample_rate_hz);
    for (size_t f = 0; f < 4; f++)
        EXPECT_DOUBLE_EQ(again.foci[f].peak_m, r.verification.foci[f].peak_m);
    haptic_table_close(&t);
    std::filesystem::remove(path);

    // Deterministic for a seed.
    pipeline::CalibrationResult r2 = pipeline::calibrate(in);
    EXPECT_EQ(r2.placement.chosen, r.placement.chosen);
    EXPECT_EQ(r2.signals[2].samples, r.signals[2].samples);
}

TEST(Calibration, Fig4RandomPlacementFocusesBetterThanTheRegularOne)
{
    // The seed's Fig. 4: at the focus instant the random pattern leaves less
    // field elsewhere on the plate than the regular one (5.16 against 3.72 dB
    // in the paper). Judged by the verification (the field the placed
    // exciters produce), not by the search's own objective: a search that
    // returned its start, or one that improved only its model, fails.
    auto read = [](const char *name) {
        const std::filesystem::path scene = std::filesystem::path(HAPTIC_SOURCE_DIR) / "scenes" / name;
        std::FILE *f = std::fopen(scene.c_str(), "rb");
        std::string text;
        char buf[4096];
        size_t n;
        while (f && (n = std::fread(buf, 1, sizeof buf, f)) > 0)
            text.append(buf, n);
        if (f)
            std::fclose(f);
        return input_of(text, name);
    };
    pipeline::CalibrationInput random = read("paper-fig4-random.toml");
    random.exciters.iterations = 400; // a shorter search than the scene's
    const pipeline::CalibrationResult r = pipeline::calibrate(random);
    const pipeline::CalibrationResult g = pipeline::calibrate(read("paper-fig4-regular.toml"));
    ASSERT_EQ(r.verification.foci.size(), 1u);
    ASSERT_EQ(g.verification.foci.size(), 1u);
    EXPECT_NE(r.placement.chosen, r.placement.regular);
    EXPECT_GT(r.verification.foci[0].field_contrast_db, g.verification.foci[0].field_contrast_db + 1.0)
        << "random " << r.verification.foci[0].field_contrast_db << " dB, regular "
        << g.verification.foci[0].field_contrast_db << " dB";
}
