// The placement search judged by the verdict (pipeline/placement_verdict.h).
// Independent truths: hand-built verifications whose verdict is known by
// construction (a ghost, a miss); and, for the search on a small plate, a
// second route to the chosen placement's figures: the same exciters given as
// a fixed placement, calibrated again from scratch (its own transfer
// simulations, no cache, no search), must give the same drives and figures.
#include "pipeline/calibrate.h"
#include "pipeline/placement_verdict.h"
#include "scene/calibration_input.h"

#include "scene_text.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <string>

using namespace calib;
using scene_text::replace;

namespace {

pipeline::FocusMetrics focus(double peak_um, double others_um, double area_um)
{
    pipeline::FocusMetrics m;
    const double thr = 5e-6;
    m.peak_m = peak_um * 1e-6;
    m.max_other_foci_m = others_um * 1e-6;
    m.other_foci_contrast_db = 20 * std::log10(peak_um / others_um);
    m.max_whole_area_m = area_um * 1e-6;
    m.whole_area_contrast_db = 20 * std::log10(peak_um / area_um);
    m.whole_area = true;
    m.crosses_threshold = m.peak_m >= thr;
    m.others_below_threshold = m.max_other_foci_m < thr;
    m.whole_area_below_threshold = m.max_whole_area_m < thr;
    return m;
}

// A 250 x 200 mm acrylic plate, 4 exciters, 2 foci at 1.2 kHz: a calibration in about a second.
std::string small_scene() { return scene_text::load("placement-verdict-small.toml"); }

} // namespace

// A placement whose foci stand clear of each other but which rings above the
// threshold between them (the proxy's favourite: 8 dB over the other foci)
// loses to one that is quieter everywhere though its contrast over the other
// foci is smaller; a focus that misses the threshold loses to one that does
// not, whatever its contrast.
TEST(PlacementVerdict, AGhostLosesToAClearPlacementTheProxyRanksLower)
{
    pipeline::Verification ghost, clear;
    ghost.foci = {focus(10, 4.0, 6.0), focus(10, 4.0, 4.0)}; // focus 1: a ghost at 6 um beyond lambda/2
    clear.foci = {focus(10, 4.7, 4.8), focus(10, 4.7, 4.8)};
    ASSERT_GT(ghost.foci[0].other_foci_contrast_db, clear.foci[0].other_foci_contrast_db); // what the proxy sees
    EXPECT_FALSE(ghost.foci[0].passes());
    EXPECT_TRUE(ghost.foci[1].passes());
    EXPECT_TRUE(clear.foci[0].passes() && clear.foci[1].passes());
    EXPECT_TRUE(pipeline::verdict_better(clear, ghost, 10e-6));
    EXPECT_FALSE(pipeline::verdict_better(ghost, clear, 10e-6));
    EXPECT_FALSE(pipeline::verdict_better(clear, clear, 10e-6));

    // Same count passing: the larger worst whole-area contrast wins.
    pipeline::Verification thin = clear;
    thin.foci[1] = focus(10, 4.7, 4.95);
    EXPECT_TRUE(pipeline::verdict_better(clear, thin, 10e-6));
    EXPECT_FALSE(pipeline::verdict_better(thin, clear, 10e-6));

    // A focus below the threshold fails, however quiet the rest.
    pipeline::Verification weak = clear;
    weak.foci[0] = focus(4.9, 1.0, 1.0);
    EXPECT_FALSE(weak.foci[0].passes());
    EXPECT_TRUE(pipeline::verdict_better(thin, weak, 10e-6));
    EXPECT_EQ(pipeline::summarize_verdict(weak.foci).passing, 1u);
    EXPECT_EQ(pipeline::summarize_verdict(ghost.foci).worst, 0u);

    // Exciters that cannot reach the scene's 10 um play their foci at full
    // scale, 7.5 um, and their ghosts with them: both foci pass, but not at the
    // amplitude asked for, and that ranks below one focus passing at 10 um.
    pipeline::Verification low;
    low.foci = {focus(7.5, 3.0, 4.5), focus(7.5, 3.0, 4.5)};
    ASSERT_EQ(pipeline::summarize_verdict(low.foci).passing, 2u);
    EXPECT_EQ(pipeline::passing_at_target(low, 10e-6), 0u);
    EXPECT_EQ(pipeline::passing_at_target(ghost, 10e-6), 1u);
    EXPECT_TRUE(pipeline::verdict_better(ghost, low, 10e-6));
    EXPECT_FALSE(pipeline::verdict_better(low, ghost, 10e-6));
    EXPECT_TRUE(pipeline::verdict_better(low, ghost, 7.5e-6)); // a scene that asks for 7.5 um
}

// On a small plate the search by the verdict judges the model's choice and
// the regular pattern at least, keeps the best judged placement, and its
// table is what the same exciters give when calibrated again from scratch.
TEST(PlacementVerdict, SearchKeepsTheBestJudgedPlacementAndItsFiguresHold)
{
    const std::string text = small_scene();
    const pipeline::CalibrationInput in = scene::calibration_input(text, "small.toml");
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    const pipeline::PlacementReport &p = r.placement;
    ASSERT_GE(p.judged.size(), 2u);
    EXPECT_TRUE(std::any_of(p.judged.begin(), p.judged.end(), [](const auto &j) { return j.regular; }));
    const pipeline::VerdictSummary vs = pipeline::summarize_verdict(r.verification.foci);
    const std::size_t at_target = pipeline::passing_at_target(r.verification, in.pulse.amplitude_m);
    double worst = INFINITY;
    for (const pipeline::FocusMetrics &m : r.verification.foci)
        worst = std::min(worst, m.whole_area_contrast_db);
    bool found = false;
    for (const pipeline::PlacementReport::Judged &j : p.judged) {
        // No judged placement ranks above the one kept.
        const bool below =
            j.passing_at_target < at_target ||
            (j.passing_at_target == at_target &&
             (j.passing < vs.passing || (j.passing == vs.passing && j.worst_whole_area_db <= worst + 1e-12)));
        EXPECT_TRUE(below) << j.passing_at_target << " / " << j.passing << " foci, " << j.worst_whole_area_db
                           << " dB against " << at_target << " / " << vs.passing << ", " << worst;
        if (j.chosen == p.chosen) {
            found = true;
            EXPECT_EQ(j.passing, vs.passing);
            EXPECT_EQ(j.passing_at_target, at_target);
            EXPECT_DOUBLE_EQ(j.worst_whole_area_db, worst);
        }
    }
    EXPECT_TRUE(found);
    ASSERT_EQ(r.exciters.size(), p.chosen.size());
    for (std::size_t c = 0; c < p.chosen.size(); c++) {
        EXPECT_EQ(r.exciters[c].x_m, p.sites[p.chosen[c]].x_m);
        EXPECT_EQ(r.exciters[c].y_m, p.sites[p.chosen[c]].y_m);
    }

    // The second route: the chosen exciters as a fixed placement, from scratch.
    std::string positions = "positions_m = [";
    for (std::size_t c = 0; c < r.exciters.size(); c++) {
        char b[80];
        std::snprintf(b, sizeof b, "%s[%.17g, %.17g]", c ? ", " : "", r.exciters[c].x_m, r.exciters[c].y_m);
        positions += b;
    }
    positions += "]\n";
    const std::string fixed = replace(text, "placement = \"random\"\n", "placement = \"fixed\"\n" + positions);
    const pipeline::CalibrationResult again = pipeline::calibrate(scene::calibration_input(fixed, "fixed.toml"));
    ASSERT_EQ(again.signals.size(), r.signals.size());
    for (std::size_t f = 0; f < r.signals.size(); f++) {
        EXPECT_EQ(again.signals[f].samples, r.signals[f].samples) << "focus " << f;
        EXPECT_NEAR(again.verification.foci[f].peak_m, r.verification.foci[f].peak_m, 1e-12);
        EXPECT_NEAR(again.verification.foci[f].max_whole_area_m, r.verification.foci[f].max_whole_area_m, 1e-12);
        EXPECT_EQ(again.verification.foci[f].passes(), r.verification.foci[f].passes());
    }
}

// verdict_rounds = 0 keeps the contrast model's choice: nothing is judged.
TEST(PlacementVerdict, ZeroRoundsKeepsTheModelsChoice)
{
    const std::string text = replace(small_scene(), "iterations = 200\n", "iterations = 200\nverdict_rounds = 0\n");
    const pipeline::CalibrationResult r = pipeline::calibrate(scene::calibration_input(text, "small.toml"));
    EXPECT_TRUE(r.placement.judged.empty());
    EXPECT_TRUE(r.placement.ghost_probes.empty());
}
