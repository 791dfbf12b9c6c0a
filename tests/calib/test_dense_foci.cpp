// Dense focus grids: the [foci] pitch_m grid and its refusals, the subset of
// foci the placement search weighs (deterministic, bounded, covering), the
// whole-area contrast map of the report, and a pitch grid of more foci than
// the subset cap calibrated end to end.
#include "pipeline/calibrate.h"
#include "pipeline/placement/focus_subset.h"
#include "pipeline/table_writer.h"
#include "report/colormap.h"
#include "report/contrast_map.h"
#include "scene/calibration_input.h"
#include "scene/toml_fields.h"

#include <haptic_table.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <string>

#include "scene_text.h"

using namespace calib;
using pipeline::Point;
using scene_text::replace;

namespace {

std::vector<Point> square_grid(int n, double pitch)
{
    std::vector<Point> v;
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++)
            v.push_back({i * pitch, j * pitch});
    return v;
}

// Upper bound on the covering radius r of a farthest-point subset of K
// points in a w x h rectangle, independent of the algorithm's code: its
// members are pairwise at least r apart (each was the farthest when added),
// so K disks of radius r/2 around them are disjoint and lie in the rectangle
// grown by r/2: K pi r^2 / 4 <= (w + r)(h + r). The largest r that satisfies
// it, by bisection.
double packing_bound(std::size_t K, double w, double h)
{
    double lo = 0, hi = 10 * (w + h);
    for (int it = 0; it < 200; it++) {
        const double r = (lo + hi) / 2;
        (double(K) * std::numbers::pi * r * r / 4 <= (w + r) * (h + r) ? lo : hi) = r;
    }
    return lo;
}

// The small scene (scenes/small.toml: 0.35 m square acrylic, 1200 Hz pulse,
// lambda/2 = 40 mm) with a 60 mm pitch grid of 5 x 5 foci and a placement
// subset of 4.
std::string dense_scene()
{
    const std::string named = replace(scene_text::load("small.toml"), "name = \"small\"", "name = \"small-dense\"");
    return replace(replace(named, "grid = [2, 2]", "pitch_m = 0.06"), "iterations = 300",
                   "iterations = 300\nplacement_foci = 4");
}

std::string scene_error(const std::string &text)
{
    try {
        scene::calibration_input(text, "dense.toml");
    } catch (const scene::SceneError &e) {
        return e.what();
    }
    return "";
}

std::string refusal(const std::string &text)
{
    try {
        pipeline::check_feasible(scene::calibration_input(text, "dense.toml"));
    } catch (const std::invalid_argument &e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(FocusSubset, FociThatFitAreAllKeptInSceneOrder)
{
    const std::vector<Point> nine = square_grid(3, 0.167);
    const pipeline::FocusSubset s = pipeline::farthest_point_subset(nine, 16);
    EXPECT_EQ(s.members, (std::vector<std::size_t>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
    EXPECT_EQ(s.covering_radius_m, 0.0);
    EXPECT_EQ(pipeline::farthest_point_subset(nine, 9).members.size(), 9u);
}

TEST(FocusSubset, FiveByFiveGridByHand)
{
    // Unit pitch, indices j * 5 + i. Start: the centre (2, 2) = 12. Farthest
    // from it: the four corners at 2 sqrt 2, taken lowest index first as each
    // stays at 2 sqrt 2 from the centre: 0, 4, 20, 24. Then every remaining
    // point is within 2 of a member, the edge midpoints exactly 2.
    const std::vector<Point> g = square_grid(5, 1.0);
    const pipeline::FocusSubset s = pipeline::farthest_point_subset(g, 5);
    EXPECT_EQ(s.members, (std::vector<std::size_t>{12, 0, 4, 20, 24}));
    EXPECT_DOUBLE_EQ(s.covering_radius_m, 2.0);
    EXPECT_DOUBLE_EQ(pipeline::covering_radius(g, s.members), 2.0);
    // One more: the lowest-indexed of the four edge midpoints at 2, (2, 0).
    const pipeline::FocusSubset six = pipeline::farthest_point_subset(g, 6);
    EXPECT_EQ(six.members.back(), 2u);
}

TEST(FocusSubset, DenseGridIsDeterministicBoundedAndCovered)
{
    // The dense Fig. 7 panel: 13 x 13 foci 40 mm apart over 480 mm.
    const std::vector<Point> g = square_grid(13, 0.04);
    for (std::size_t cap : {5u, 9u, 16u, 40u}) {
        SCOPED_TRACE("cap " + std::to_string(cap));
        const pipeline::FocusSubset s = pipeline::farthest_point_subset(g, cap);
        ASSERT_EQ(s.members.size(), cap);
        EXPECT_EQ(pipeline::farthest_point_subset(g, cap).members, s.members); // deterministic
        std::vector<std::size_t> sorted = s.members;
        std::sort(sorted.begin(), sorted.end());
        EXPECT_EQ(std::unique(sorted.begin(), sorted.end()), sorted.end()); // no focus twice
        // Every focus within the stated radius of a member (brute force) ...
        for (const Point &p : g) {
            double near = 1e9;
            for (std::size_t m : s.members)
                near = std::min(near, dist(p, g[m]));
            EXPECT_LE(near, s.covering_radius_m + 1e-12);
        }
        // ... which the packing argument bounds, and the members are that far apart.
        EXPECT_LE(s.covering_radius_m, packing_bound(cap, 0.48, 0.48));
        for (std::size_t a = 0; a < cap; a++)
            for (std::size_t b = a + 1; b < cap; b++)
                EXPECT_GE(dist(g[s.members[a]], g[s.members[b]]), s.covering_radius_m - 1e-12);
        // The centre and the four corners are members: the subset spans the area.
        for (std::size_t must : {84u, 0u, 12u, 156u, 168u})
            EXPECT_NE(std::find(s.members.begin(), s.members.end(), must), s.members.end()) << must;
    }
    // 16 of 169 leave no focus farther than 120 mm (3 pitches) from a member.
    EXPECT_LE(pipeline::farthest_point_subset(g, 16).covering_radius_m, 0.12 + 1e-12);
    // With lambda/2 = 80.7 mm as the least separation it stops before a cap
    // of 40: every focus within lambda/2 of a member, no two members closer.
    const double half = 0.0807;
    const pipeline::FocusSubset s = pipeline::farthest_point_subset(g, 40, half);
    EXPECT_LT(s.members.size(), 40u);
    EXPECT_LE(pipeline::covering_radius(g, s.members), half);
    for (std::size_t a = 0; a < s.members.size(); a++)
        for (std::size_t b = a + 1; b < s.members.size(); b++)
            EXPECT_GT(dist(g[s.members[a]], g[s.members[b]]), half);
}

TEST(FocusSubset, ScatteredFociAreCoveredWithinThePackingBound)
{
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> x(0.0, 1.2), y(0.0, 0.8);
    std::vector<Point> pts(400);
    for (Point &p : pts)
        p = {x(rng), y(rng)};
    const pipeline::FocusSubset s = pipeline::farthest_point_subset(pts, 16);
    ASSERT_EQ(s.members.size(), 16u);
    EXPECT_DOUBLE_EQ(pipeline::covering_radius(pts, s.members), s.covering_radius_m);
    EXPECT_LE(s.covering_radius_m, packing_bound(16, 1.2, 0.8));
}

TEST(FocusSubset, CapFollowsTheContrastModelMemory)
{
    // Fig. 7: 464 sites, 744 lags: the default 9 take 464 x 81 x 744 x 4 B =
    // 112 MB; 13 would take 233 MB, 14 over the 256 MiB bound (271 MB).
    EXPECT_EQ(pipeline::placement_focus_cap(std::nullopt, 464, 744), 9u);
    EXPECT_EQ(pipeline::placement_focus_cap(std::nullopt, 4 * 464, 744), 6u); // 4x the sites: 13 / 2
    EXPECT_EQ(pipeline::placement_focus_cap(std::nullopt, 40, 200), 9u);      // small model: the default
    EXPECT_EQ(pipeline::placement_focus_cap(std::nullopt, 1e6, 1e4), 4u);     // never below 4
    EXPECT_EQ(pipeline::placement_focus_cap(7u, 1e6, 1e4), 7u);               // the scene's key wins
    EXPECT_DOUBLE_EQ(pipeline::contrast_model_lags(0.2, 0.3, 2866), 172 + 573 - 1);
}

TEST(DenseFoci, PitchFillsTheActiveAreaRowByRow)
{
    const std::string narrow =
        replace(dense_scene(), "rect_m = [0.05, 0.05, 0.30, 0.30]", "rect_m = [0.05, 0.05, 0.30, 0.21]");
    scene::Scene s = scene::parse_scene(narrow, "p.toml");
    // x: 250 mm / 60 mm -> 5 points over 240 mm, 5 mm in; y: 160 mm -> 3 points over 120 mm, 20 mm in.
    ASSERT_EQ(s.foci->points.size(), 15u);
    EXPECT_DOUBLE_EQ(*s.foci->pitch_m, 0.06);
    for (std::size_t k = 0; k < 15; k++) {
        EXPECT_EQ(s.foci->points[k].id, k + 1);
        EXPECT_NEAR(s.foci->points[k].at.x_m, 0.055 + 0.06 * double(k % 5), 1e-12);
        EXPECT_NEAR(s.foci->points[k].at.y_m, 0.07 + 0.06 * double(k / 5), 1e-12);
    }
    // The dense Fig. 7 grid: 40 mm over the 500 mm area, 13 x 13.
    const std::string text = replace(replace(dense_scene(), "pitch_m = 0.06", "pitch_m = 0.04"),
                                     "rect_m = [0.05, 0.05, 0.30, 0.30]", "rect_m = [0.1, 0.1, 0.6, 0.6]");
    const std::string plate = replace(text, "size_m = [0.35, 0.35]", "size_m = [0.7, 0.7]");
    EXPECT_EQ(scene::parse_scene(plate, "d.toml").foci->points.size(), 169u);
}

TEST(DenseFoci, BadPitchAndFociOutsideTheActiveAreaAreRefusedInOneLine)
{
    const struct {
        const char *from, *to, *message;
    } parse_cases[] = {
        {"pitch_m = 0.06", "pitch_m = 0", "dense.toml: foci.pitch_m: must be > 0, got 0"},
        {"pitch_m = 0.06", "pitch_m = -0.04", "dense.toml: foci.pitch_m: must be > 0, got -0.04"},
        {"pitch_m = 0.06", "pitch_m = 0.005",
         "dense.toml: foci.pitch_m: 0.005 m fills the 0.25 x 0.25 m active area with 2601 foci, more than 1024"},
        {"pitch_m = 0.06", "pitch_m = 0.06\ngrid = [2, 2]",
         "dense.toml: foci.pitch_m: give exactly one of grid = [nx, ny], pitch_m = p or points_m"},
        {"pitch_m = 0.06", "pitch_m = 0.06\nids = [1]", "dense.toml: foci.ids: only with points_m"},
        {"placement_foci = 4", "placement_foci = 1",
         "dense.toml: exciters.placement_foci: must lie in [2, 1024], got 1"},
    };
    for (const auto &c : parse_cases) {
        const std::string err = scene_error(replace(dense_scene(), c.from, c.to));
        EXPECT_EQ(err.substr(0, std::string(c.message).size()), c.message) << c.to;
        EXPECT_EQ(err.find('\n'), std::string::npos) << err;
    }
    // A focus on the plate but outside the active area, before simulating.
    const std::string outside =
        refusal(replace(dense_scene(), "pitch_m = 0.06", "points_m = [[0.1, 0.1], [0.32, 0.1]]"));
    EXPECT_EQ(outside, "foci.points_m: focus 2 at (0.32, 0.1) m is outside the active area [0.05, 0.05, 0.3, 0.3]");
    // A pitch finer than the plate grid, once the grid is known: h = 6.5 mm
    // at 8 points per wavelength at the pulse's 2.9 kHz band edge, 13 mm at 4.
    EXPECT_EQ(refusal(dense_scene()), "");
    EXPECT_EQ(refusal(replace(dense_scene(), "pitch_m = 0.06", "pitch_m = 0.01")), "");
    const std::string finer = refusal(replace(replace(dense_scene(), "pitch_m = 0.06", "pitch_m = 0.01"),
                                              "points_per_wavelength = 8", "points_per_wavelength = 4"));
    EXPECT_EQ(finer.rfind("foci.pitch_m: 0.01 m is finer than the simulation grid spacing (", 0), 0u) << finer;
    EXPECT_EQ(finer.find('\n'), std::string::npos);
}

TEST(ContrastMap, EachSampleTakesItsNearestFocusValue)
{
    // Two foci on a 1 m square, 3 x 3 samples: x = 0 and 0.5 are nearer the
    // focus at x = 0.2, x = 1 nearer the one at x = 0.9, at every y.
    const report::FieldMap m = report::nearest_focus_map({{0.2, 0.5}, {0.9, 0.5}}, {1.0, 2.0}, {0, 0, 1, 1}, 3);
    ASSERT_EQ(m.nx, 3);
    ASSERT_EQ(m.ny, 3);
    EXPECT_DOUBLE_EQ(m.dx_m, 0.5);
    for (int j = 0; j < 3; j++)
        EXPECT_EQ((std::vector<float>(m.value.begin() + 3 * j, m.value.begin() + 3 * j + 3)),
                  (std::vector<float>{1, 1, 2}));
    // Painted: the pixel at each focus has the colour of its own value.
    report::FieldStyle s;
    s.unit = "dB";
    s.scale = 1;
    s.vmin = 0.0;
    s.vmax = 4.0;
    const report::FieldMap fine = report::nearest_focus_map({{0.2, 0.5}, {0.9, 0.5}}, {1.0, 3.0}, {0, 0, 1, 1});
    const report::FieldLayout l = report::field_layout(fine, s);
    const report::Image img = report::render_field(fine, s);
    const int y = static_cast<int>(l.px_y(0.5));
    EXPECT_EQ(img.at(static_cast<int>(l.px_x(0.2)), y), report::viridis(0.25));
    EXPECT_EQ(img.at(static_cast<int>(l.px_x(0.9)), y), report::viridis(0.75));
    EXPECT_THROW((report::nearest_focus_map({}, {}, {0, 0, 1, 1})), std::invalid_argument);
}

TEST(DenseCalibration, PitchGridOfMoreFociThanTheSubsetEndToEnd)
{
    // The seed's time reversal (equal gains): with minimax gains the search
    // here settles on a placement whose weakest focus cannot reach 10 um
    // at full scale with the small scene's 0.5 N exciters.
    pipeline::CalibrationInput in = scene::calibration_input(dense_scene(), "dense.toml");
    in.calibration.exciter_gains = pipeline::ExciterGainsMode::equal;
    const std::size_t K = in.foci.points.size();
    ASSERT_EQ(K, 25u);
    // Count the placement simulations as they run (the progress's count of
    // those done; simulations side by side in lanes report together).
    std::size_t placement_runs = 0;
    const pipeline::CalibrationResult r = pipeline::calibrate(in, [&](const std::string &stage, size_t done, size_t) {
        if (stage == "simulate")
            placement_runs = std::max(placement_runs, done);
    });
    EXPECT_EQ(placement_runs, 4u); // the cap: 4 foci, no probe points (a grid of 25 samples the field)
    EXPECT_EQ(r.placement.simulations, placement_runs);
    EXPECT_EQ(r.placement.focus_subset.size(), 4u);
    EXPECT_EQ(r.signals.size(), K);

    // The table holds every focus, in scene order.
    const std::string path = (std::filesystem::temp_directory_path() / "calib-dense.htab").string();
    pipeline::write_table(path, in, r);
    haptic_table t{};
    haptic_table_error err{};
    ASSERT_EQ(haptic_table_open(path.c_str(), &t, &err), 0) << err.message;
    EXPECT_EQ(t.focus_count, K);
    EXPECT_EQ(t.channel_count, 8u);
    for (uint32_t f = 0; f < K; f++) {
        haptic_focus_info fi;
        haptic_table_focus(&t, f, &fi);
        EXPECT_EQ(fi.id, in.foci.points[f].id);
        EXPECT_NEAR(fi.x_m, in.foci.points[f].at.x_m, 1e-6);
        EXPECT_NEAR(fi.y_m, in.foci.points[f].at.y_m, 1e-6);
    }
    haptic_table_close(&t);
    std::filesystem::remove(path);

    // Every focus, weighed by the search or not, forms where it should: its
    // target peak, and the largest |w| of the plate at its instant on the
    // observation lattice within one lattice step of it.
    const pipeline::Verification &v = r.verification;
    ASSERT_EQ(v.foci.size(), K);
    const double step = v.grid_h_m;
    ASSERT_GT(step, 0);
    for (std::size_t f = 0; f < K; f++) {
        const pipeline::FocusMetrics &m = v.foci[f];
        SCOPED_TRACE("focus " + std::to_string(m.id));
        EXPECT_TRUE(m.whole_area);
        EXPECT_TRUE(std::isfinite(m.whole_area_contrast_db));
        EXPECT_TRUE(m.crosses_threshold);
        EXPECT_NEAR(m.peak_m, 10e-6, 0.05e-6);
        // The other-foci criterion counts the foci beyond lambda/2: their
        // largest sample, read from the traces here, is what it reports (the
        // reported peak is refined between samples, at 4 samples per period
        // of the band edge: a few % above).
        double far = 0;
        for (std::size_t g = 0; g < K; g++)
            if (g != f && dist(v.foci[g].at, m.at) > m.lambda_half_m)
                for (double w : v.traces[f][g])
                    far = std::max(far, std::abs(w));
        EXPECT_GE(m.max_other_foci_m, far);
        EXPECT_LE(m.max_other_foci_m, 1.1 * far);
        EXPECT_EQ(m.others_below_threshold, m.max_other_foci_m < in.calibration.threshold_m);
        const std::vector<float> &snap = v.snapshots[f];
        const auto n = static_cast<std::size_t>(std::max_element(snap.begin(), snap.end()) - snap.begin());
        const Point at{double(n % std::size_t(v.grid_nx + 1)) * step, double(n / std::size_t(v.grid_nx + 1)) * step};
        EXPECT_LE(dist(at, m.at), step) << "largest |w| at (" << at.x_m << ", " << at.y_m << ")";
    }
}
