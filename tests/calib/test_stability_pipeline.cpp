// Stability suite, pipeline side: degenerate inputs give
// clear errors, never NaN gains, and a diverged simulation never reaches a
// table. Complements test_time_reversal.cpp (all-zero and NaN recordings in
// make_drive_signals) and test_placement.cpp (bands that cannot hold the
// exciters).
#include "pipeline/calibrate.h"
#include "pipeline/design/time_reversal.h"
#include "pipeline/placement/placement.h"
#include "pipeline/table_writer.h"
#include "scene/calibration_input.h"

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

using namespace calib;
using namespace calib::pipeline;

namespace {

const std::string unreachable_scene = std::string(HAPTIC_SOURCE_DIR) + "/scenes/test-stability-unreachable.toml";

std::string read_text(const std::string &path)
{
    std::ifstream f(path, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

CalibrationInput input_of(const std::string &toml, const std::string &name)
{
    return scene::calibration_input(toml, name);
}

std::string temp_path(const std::string &leaf)
{
    return (std::filesystem::temp_directory_path() / ("haptic-stability-" + std::to_string(::getpid()) + "-" + leaf))
        .string();
}

// Mirrors `calibgen calibrate`: the table is written only after calibrate()
// returned.
std::string calibrate_to(const CalibrationInput &in, const std::string &table)
{
    try {
        CalibrationResult r = calibrate(in);
        write_table(table, in, r);
    } catch (const std::exception &e) {
        return e.what();
    }
    return {};
}

bool has(const std::string &s, const std::string &part) { return s.find(part) != std::string::npos; }

} // namespace

TEST(StabilityPipeline, ContrastModelOnAllZeroResponsesIsFiniteNotNaN)
{
    // Every response zero (nothing reaches any site): the predicted contrast
    // is 0 dB (nothing better than anything else), never NaN, and the search
    // still returns a valid, finite result.
    std::vector<Point> sites;
    for (int i = 0; i < 12; ++i)
        sites.push_back({0.01 * i, 0.0});
    std::vector<std::vector<std::vector<float>>> zero(3,
                                                      std::vector<std::vector<float>>(12, std::vector<float>(64, 0.f)));
    ContrastModel m(zero, 2, 20);
    const ContrastModel::Score s = m.score({0, 3, 7});
    ASSERT_EQ(s.per_focus_db.size(), 2u);
    for (double db : s.per_focus_db)
        EXPECT_EQ(db, 0.0);
    SearchOptions o;
    o.count = 3;
    o.min_spacing_m = 0.015;
    o.restarts = 2;
    o.iterations = 50;
    const SearchResult r = search_placement_contrast(sites, o, m);
    EXPECT_TRUE(std::isfinite(r.objective));
    EXPECT_EQ(r.chosen.size(), 3u);
    // One focus unreachable (its row zero), the other not: the unreachable
    // focus drives nothing, so its own and cross peaks are both zero: 0 dB;
    // the reachable one has no cross-talk from it: a large finite value.
    auto one = zero;
    for (auto &site : one[1])
        for (std::size_t n = 0; n < site.size(); ++n)
            site[n] = float(std::sin(0.3 * double(n)));
    ContrastModel m1(one, 2, 20);
    const ContrastModel::Score s1 = m1.score({0, 3, 7});
    EXPECT_TRUE(std::isfinite(s1.per_focus_db[0]));
    EXPECT_TRUE(std::isfinite(s1.per_focus_db[1]));
    EXPECT_EQ(s1.per_focus_db[0], 0.0);
    EXPECT_GT(s1.per_focus_db[1], 100);
    EXPECT_EQ(s1.worst_db, 0.0);
}

namespace {

std::vector<std::vector<double>> tiny_recordings(double scale)
{
    std::vector<std::vector<double>> rec(2, std::vector<double>(2000, 0.0));
    for (std::size_t n = 0; n < 2000; ++n)
        rec[0][n] = scale * std::sin(0.01 * double(n));
    return rec;
}

} // namespace

TEST(StabilityPipeline, TinyButNonZeroRecordingsNormalizeToFiniteSignals)
{
    // Recordings of 1e-300 m: what goes into the table (the normalized,
    // quantized signals) is finite and full scale, and the gain is finite.
    // Denormal ones are refused (next test).
    for (double scale : {1e-300, 1e-200}) {
        const DriveSignals d = make_drive_signals(tiny_recordings(scale), 48000, 0.001, {});
        double peak = 0;
        for (double v : d.normalized) {
            ASSERT_TRUE(std::isfinite(v)) << scale;
            peak = std::max(peak, std::abs(v));
        }
        EXPECT_NEAR(peak, 1.0, 1e-12) << scale;
        EXPECT_TRUE(std::isfinite(d.gain));
    }
}

// A denormal peak would make gain = 32767 / peak overflow to Inf: refused
// (or, were it ever accepted, the gain must be finite).
TEST(StabilityPipeline, DenormalPeakGivesAFiniteGainOrAClearError)
{
    for (double scale : {1e-310, 1e-320}) {
        try {
            const DriveSignals d = make_drive_signals(tiny_recordings(scale), 48000, 0.001, {});
            EXPECT_TRUE(std::isfinite(d.gain)) << scale << ": gain " << d.gain;
        } catch (const std::invalid_argument &e) {
            EXPECT_FALSE(std::string(e.what()).empty());
        }
    }
}

TEST(StabilityPipeline, FocusOnTheBoundaryIsRefusedNamingIt)
{
    std::string toml = read_text(unreachable_scene);
    ASSERT_FALSE(toml.empty()) << unreachable_scene;
    const std::string from = "points_m = [[0.06, 0.05]]";
    ASSERT_NE(toml.find(from), std::string::npos);
    toml.replace(toml.find(from), from.size(), "points_m = [[0.0, 0.05]]");
    const CalibrationInput in = input_of(toml, "boundary-focus.toml");
    try {
        check_feasible(in);
        FAIL() << "a focus on the boundary was accepted";
    } catch (const std::invalid_argument &e) {
        EXPECT_TRUE(has(e.what(), "foci: focus 1")) << e.what();
        EXPECT_TRUE(has(e.what(), "not inside the plate")) << e.what();
    }
}

TEST(StabilityPipeline, FocusTheExcitersCannotReachFailsWithTheReasonAndNoTable)
{
    // Exciters on clamped edge nodes: every recording is exactly zero. The
    // library call fails naming the focus and the reason; no table appears.
    const CalibrationInput in = input_of(read_text(unreachable_scene), unreachable_scene);
    ASSERT_NO_THROW(check_feasible(in)); // feasible on paper: the positions are in the band
    const std::string table = temp_path("unreachable.htab");
    std::filesystem::remove(table);
    const std::string m = calibrate_to(in, table);
    EXPECT_TRUE(has(m, "focus 1")) << m;
    EXPECT_TRUE(has(m, "all recordings are zero")) << m;
    EXPECT_FALSE(std::filesystem::exists(table));
}

TEST(StabilityPipeline, CalibgenExitsNonZeroAndWritesNoTable)
{
    const std::string table = temp_path("cli.htab");
    const std::string err = temp_path("cli.err");
    std::filesystem::remove(table);
    const std::string cmd = std::string("\"") + HAPTIC_CALIBGEN + "\" calibrate \"" + unreachable_scene + "\" -o \"" +
                            table + "\" -q 2> \"" + err + "\"";
    const int status = std::system(cmd.c_str());
    ASSERT_NE(status, -1);
    EXPECT_NE(status, 0);
    EXPECT_FALSE(std::filesystem::exists(table));
    EXPECT_FALSE(std::filesystem::exists(table + ".tmp"));
    const std::string msg = read_text(err);
    EXPECT_TRUE(has(msg, "all recordings are zero")) << msg;
    EXPECT_EQ(std::count(msg.begin(), msg.end(), '\n'), 1) << msg; // one line
    std::filesystem::remove(err);
}

TEST(StabilityPipeline, DivergedSimulationNeverReachesATable)
{
    // A step beyond the bound (check bypassed, as a stand-in for any source of
    // Inf/NaN in the engine): calibrate() fails naming the focus, the step and
    // the node; no table is written.
    std::string toml = read_text(unreachable_scene);
    const std::string from = "positions_m = [[0.0, 0.05], [0.12, 0.02]]";
    ASSERT_NE(toml.find(from), std::string::npos);
    toml.replace(toml.find(from), from.size(), "positions_m = [[0.01, 0.05], [0.11, 0.02]]");
    CalibrationInput in = input_of(toml, "diverging.toml");
    in.simulation.time_step_s = 1.5 * in.plate->max_time_step();
    in.simulation.engine.skip_stability_check = true;
    const std::string table = temp_path("diverged.htab");
    std::filesystem::remove(table);
    const std::string m = calibrate_to(in, table);
    EXPECT_TRUE(has(m, "focus 1")) << m;
    EXPECT_TRUE(has(m, "simulation diverged")) << m;
    EXPECT_TRUE(has(m, "at step ")) << m;
    EXPECT_TRUE(has(m, "node (i, j) = (")) << m;
    EXPECT_FALSE(std::filesystem::exists(table));
    // The same scene at a stable step calibrates and writes the table.
    in.simulation.time_step_s = 0;
    in.simulation.engine.skip_stability_check = false;
    const std::string ok = calibrate_to(in, table);
    EXPECT_EQ(ok, "");
    EXPECT_TRUE(std::filesystem::exists(table));
    std::filesystem::remove(table);
}
