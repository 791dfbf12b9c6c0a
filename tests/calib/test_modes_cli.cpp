// `calibgen modes` as a user runs it: the CSV and the shape images of a
// small scene (checked against the library on the same scene), and bad input
// refused in one line with a non-zero exit and nothing written. And the same
// modes in the report of `calibgen calibrate --modes N`.
#include "engine/modes.h"
#include "scene/scene.h"

#include <gtest/gtest.h>

#include "calibgen_run.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const std::string small_scene = std::string(HAPTIC_SOURCE_DIR) + "/scenes/test-small.toml";

using calibgen_run::Outcome;
using calibgen_run::read_text;

class ModesCli : public ::testing::Test {
  protected:
    void SetUp() override
    {
        dir_ = fs::temp_directory_path() / ("haptic-modes-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }

    Outcome calibgen(const std::string &args) const { return run("modes " + args); }
    Outcome run(const std::string &command_and_args) const { return calibgen_run::run(dir_, command_and_args); }

    // A refusal: non-zero exit, one line naming `what`, no CSV.
    void expect_refused(const std::string &args, const std::string &what) const
    {
        const Outcome r = calibgen(args + " -o \"" + csv().string() + "\"");
        EXPECT_EQ(r.exit_code, 1) << r.err;
        EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
        EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(csv()));
    }

    fs::path csv() const { return dir_ / "modes.csv"; }
    fs::path dir_;
};

std::vector<std::vector<std::string>> parse_csv(const std::string &text)
{
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        std::vector<std::string> cells;
        std::string cell;
        std::istringstream ls(line);
        while (std::getline(ls, cell, ','))
            cells.push_back(cell);
        if (!line.empty() && line.back() == ',')
            cells.push_back("");
        rows.push_back(cells);
    }
    return rows;
}

} // namespace

TEST_F(ModesCli, WritesTheLibrarysModesAndOneImagePerMode)
{
    const fs::path png = dir_ / "shapes";
    const Outcome r =
        calibgen("\"" + small_scene + "\" --count 6 -o \"" + csv().string() + "\" --png \"" + png.string() + "\"");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto rows = parse_csv(read_text(csv()));
    ASSERT_EQ(rows.size(), 7u);
    EXPECT_EQ(rows[0][0], "mode");
    EXPECT_EQ(rows[0][1], "frequency_hz");

    const calib::scene::Scene sc = calib::scene::load_scene(small_scene);
    const auto setup = calib::scene::build_plate(sc);
    const calib::engine::PlateModes modes = calib::engine::lowest_modes(*setup.plate, 6);
    for (std::size_t c = 0; c < 6; ++c) {
        const auto &row = rows[c + 1];
        ASSERT_EQ(row.size(), rows[0].size()) << c;
        EXPECT_EQ(row[0], std::to_string(c + 1));
        EXPECT_NEAR(std::stod(row[1]), modes.frequency_hz[c], 1e-7 * modes.frequency_hz[c]) << c;
        // test-small is lossy: every mode has its decay rate and T60.
        EXPECT_NEAR(std::stod(row[4]), modes.decay_rate_1_s[c], 1e-5 * modes.decay_rate_1_s[c]) << c;
        EXPECT_NEAR(std::stod(row[5]), 3 * std::log(10.0) / modes.decay_rate_1_s[c], 1e-5 * std::stod(row[5])) << c;
        if (c > 0) {
            EXPECT_GE(std::stod(row[1]), std::stod(rows[c][1]));
        }
        // Clamped on all four edges: both mirror symmetries apply.
        EXPECT_TRUE(row[6] == "sym" || row[6] == "anti") << row[6];
        EXPECT_TRUE(row[7] == "sym" || row[7] == "anti") << row[7];
        char name[32];
        std::snprintf(name, sizeof name, "mode-%03zu.png", c + 1);
        const std::string bytes = read_text(png / name);
        ASSERT_GT(bytes.size(), 8u) << name;
        EXPECT_EQ(bytes.substr(1, 3), "PNG") << name;
    }
    EXPECT_EQ(std::distance(fs::directory_iterator(png), fs::directory_iterator{}), 6);
    EXPECT_EQ(rows[1][6] + rows[1][7], "symsym"); // the fundamental
}

TEST_F(ModesCli, RefusesBadInputInOneLine)
{
    const std::string scene = "\"" + small_scene + "\"";
    expect_refused(scene + " --count 0", "--count 0: must be at least 1");
    expect_refused(scene + " --count -2", "--count -2: must be at least 1");
    expect_refused("\"" + (dir_ / "missing.toml").string() + "\" --count 3", "missing.toml: cannot open scene file");
    // More modes than grid nodes: refused before anything is built.
    const calib::engine::Grid g = calib::scene::plate_grid(calib::scene::load_scene(small_scene));
    expect_refused(scene + " --count " + std::to_string(g.node_count()), "nodes");
    expect_refused(scene + " --max-memory 1 --count 3", "refused before building the operator");
    // Fewer nodes free to move than modes asked for: a clamped plate of
    // 6 x 4 cells has 35 nodes, 15 of them free.
    std::string text = read_text(small_scene);
    text.replace(text.find("points_per_wavelength = 20"), 26, "grid_spacing_m = 0.05");
    const fs::path coarse = dir_ / "coarse.toml";
    std::ofstream(coarse) << text;
    expect_refused("\"" + coarse.string() + "\" --count 20", "only 15 nodes free to move");
    // An output directory that does not exist: refused before the work.
    const Outcome r = calibgen(scene + " --count 3 -o \"" + (dir_ / "no" / "such" / "modes.csv").string() + "\"");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find("cannot write"), std::string::npos) << r.err;
}

// The report's modes are the library's modes of the calibration's own plate
// (same grid), in metrics.json and as images in index.html; --modes is checked
// before the calibration runs.
TEST_F(ModesCli, CalibrateReportShowsTheLowestModes)
{
    const std::string scene = std::string(HAPTIC_SOURCE_DIR) + "/scenes/test-study-small.toml";
    const fs::path table = dir_ / "t.htab", report = dir_ / "r";
    const Outcome r = run("calibrate -q \"" + scene + "\" -o \"" + table.string() + "\" --report \"" + report.string() +
                          "\" --modes 4");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const calib::scene::Scene sc = calib::scene::load_scene(scene);
    const calib::engine::PlateModes modes = calib::engine::lowest_modes(*calib::scene::build_plate(sc).plate, 4);
    const std::string json = read_text(report / "metrics.json");
    const std::size_t at = json.find("\"modes\"");
    ASSERT_NE(at, std::string::npos) << json;
    std::size_t pos = at;
    for (std::size_t c = 0; c < 4; ++c) {
        pos = json.find("\"frequency_hz\"", pos);
        ASSERT_NE(pos, std::string::npos) << c;
        pos = json.find(':', pos) + 1;
        EXPECT_NEAR(std::stod(json.substr(pos, 40)), modes.frequency_hz[c], 1e-9 * modes.frequency_hz[c]) << c;
    }
    EXPECT_EQ(json.find("\"frequency_hz\"", pos), std::string::npos); // four, no more
    const std::string html = read_text(report / "index.html");
    EXPECT_NE(html.find("<h2>Plate modes</h2>"), std::string::npos);
    std::size_t images = 0;
    for (std::size_t p = html.find("<img alt='mode "); p != std::string::npos; p = html.find("<img alt='mode ", p + 1))
        ++images;
    EXPECT_EQ(images, 4u);

    // Without --modes nothing is computed and the report has no such section.
    const fs::path plain = dir_ / "plain";
    ASSERT_EQ(run("calibrate -q \"" + scene + "\" -o \"" + table.string() + "\" --report \"" + plain.string() + "\"")
                  .exit_code,
              0);
    EXPECT_EQ(read_text(plain / "metrics.json").find("\"modes\""), std::string::npos);
    EXPECT_EQ(read_text(plain / "index.html").find("Plate modes"), std::string::npos);

    // Refused before the calibration, in one line, no table written.
    fs::remove(table);
    for (const auto &[args, what] :
         {std::pair<std::string, std::string>{" --modes 3", "give --report DIR too"},
          {" --report \"" + report.string() + "\" --modes -1", "--modes -1: must be from 1"},
          {" --report \"" + report.string() + "\" --modes 1000000", "--modes 1000000: must be from 1"}}) {
        const Outcome bad = run("calibrate -q \"" + scene + "\" -o \"" + table.string() + "\"" + args);
        EXPECT_EQ(bad.exit_code, 1) << args;
        EXPECT_EQ(std::count(bad.err.begin(), bad.err.end(), '\n'), 1) << bad.err;
        EXPECT_NE(bad.err.find(what), std::string::npos) << bad.err;
        EXPECT_FALSE(fs::exists(table)) << args;
    }
}
