// The bench step end to end on the command line, on a small plate: plan,
// sensors, a recording made on a "real" twin (bench-record), the fit, the
// fitted scene read back, the report; verify --exciters scene; refusals in
// one line with nothing written.
#include "scene/scene.h"

#include <gtest/gtest.h>

#include "calibgen_run.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using namespace calib;
using calibgen_run::Outcome;
using calibgen_run::read_text;

namespace {

const std::string scenes = std::string(HAPTIC_SOURCE_DIR) + "/tests/calib/scenes/";

std::string replaced(std::string text, const std::string &from, const std::string &to)
{
    const auto at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos)
        text.replace(at, from.size(), to);
    return text;
}

class FitCli : public calibgen_run::Workdir {
  protected:
    FitCli() : Workdir("haptic-fit-cli") {}
};

} // namespace

TEST_F(FitCli, PlanRecordFitAndTheFittedScene)
{
    const std::string nominal = scenes + "inverse.toml";
    // The twin: the modulus -4 % (acrylic's 4.76 GPa), the exciters moved 2 mm, gains off.
    std::string twin = read_text(nominal);
    twin = replaced(twin, "material = \"acrylic\"",
                    "material = { name = \"acrylic\", density_kg_m3 = 1200, youngs_pa = 4.5696e9, poisson = 0.38 }");
    twin = replaced(twin, "[[0.021, 0.033], [0.273, 0.205], [0.262, 0.024], [0.035, 0.221]]",
                    "[[0.023, 0.033], [0.273, 0.203], [0.260, 0.024], [0.035, 0.223]]\n"
                    "force_gains = [1.1, 0.9, 1.0, 1.05]");
    twin = replaced(twin, "points_per_wavelength = 8", "points_per_wavelength = 12");
    std::ofstream(dir / "twin.toml") << twin;
    const fs::path bench = dir / "bench";
    ASSERT_EQ(run("measure-plan \"" + nominal + "\" -o \"" + bench.string() + "\"").exit_code, 0);
    {
        std::ofstream m(bench / "measurements.toml", std::ios::app);
        const char *at[] = {"0.11, 0.09", "0.19, 0.15", "0.14, 0.17"};
        for (int s = 0; s < 3; s++)
            m << "\n[[sensor]]\nposition_m = [" << at[s] << "]\nchannel = " << s
              << "\nquantity = \"acceleration\"\nunits_per_count = 2000.0\n";
    }
    Outcome r = run("bench-record \"" + (dir / "twin.toml").string() + "\" \"" +
                    (bench / "measurements.toml").string() + "\" --noise-db -40 -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_TRUE(fs::exists(bench / "rec.wav"));
    const fs::path fitted = dir / "fitted.toml", report = dir / "fit";
    r = run("fit \"" + nominal + "\" \"" + (bench / "measurements.toml").string() + "\" -o \"" + fitted.string() +
            "\" --report \"" + report.string() + "\" --model-ppw 10 --window-ms 20 -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(out.find("[panel] speed_ratio = "), std::string::npos) << out;
    EXPECT_TRUE(fs::exists(report / "index.html"));
    EXPECT_TRUE(fs::exists(report / "fit.json"));
    // The fitted scene reads as a scene: fixed exciters near the twin's, with gains, E about 0.96 x.
    const scene::Scene f = scene::load_scene(fitted.string());
    ASSERT_TRUE(f.exciters.has_value());
    EXPECT_EQ(f.exciters->placement, pipeline::PlacementMode::fixed);
    ASSERT_EQ(f.exciters->force_gains.size(), 4u);
    EXPECT_NEAR(f.plate.material.youngs_pa / 4.76e9, 0.96, 0.01);
    EXPECT_NEAR(f.exciters->positions[0].x_m, 0.023, 0.002);
    EXPECT_NEAR(f.exciters->force_gains[1] / 0.9, 1.0, 0.1);
    // The twin's own exciters verify a table: a table of the fitted scene.
    r = run("calibrate \"" + fitted.string() + "\" -o \"" + (dir / "t.htab").string() + "\" -q");
    ASSERT_NE(r.exit_code, 1) << r.err; // 0 or 3 (the verdict): a table was written
    r = run("verify \"" + (dir / "twin.toml").string() + "\" \"" + (dir / "t.htab").string() +
            "\" --exciters scene -q");
    EXPECT_NE(r.exit_code, 1) << r.err;
    r = run("verify \"" + scenes + "small.toml\" \"" + (dir / "t.htab").string() + "\" --exciters scene -q");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("--exciters scene needs placement = \"fixed\""), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
}

// --try-edges: a twin on simply supported edges, the scene's clamped ones;
// the fit keeps the condition that fits, and the fitted scene says it.
TEST_F(FitCli, TryEdgesKeepsTheConditionThatFits)
{
    const std::string nominal = scenes + "inverse.toml";
    std::string twin = replaced(read_text(nominal), "edges = \"clamped\"", "edges = \"simply_supported\"");
    twin = replaced(twin, "points_per_wavelength = 8", "points_per_wavelength = 12");
    std::ofstream(dir / "twin.toml") << twin;
    const fs::path bench = dir / "bench";
    ASSERT_EQ(run("measure-plan \"" + nominal + "\" -o \"" + bench.string() + "\"").exit_code, 0);
    {
        std::ofstream m(bench / "measurements.toml", std::ios::app);
        const char *at[] = {"0.11, 0.09", "0.19, 0.15"};
        for (int s = 0; s < 2; s++)
            m << "\n[[sensor]]\nposition_m = [" << at[s] << "]\nchannel = " << s
              << "\nquantity = \"acceleration\"\nunits_per_count = 2000.0\n";
    }
    ASSERT_EQ(run("bench-record \"" + (dir / "twin.toml").string() + "\" \"" + (bench / "measurements.toml").string() +
                  "\" --noise-db -40 -q")
                  .exit_code,
              0);
    const fs::path fitted = dir / "fitted.toml";
    const Outcome r =
        run("fit \"" + nominal + "\" \"" + (bench / "measurements.toml").string() + "\" -o \"" + fitted.string() +
            "\" --try-edges --no-positions --no-gains --model-ppw 10 --window-ms 20 -q");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    std::printf("%s", out.substr(0, out.find("  parameter")).c_str()); // the conditions' residuals
    EXPECT_NE(out.find("edges simply_supported: residual"), std::string::npos) << out;
    EXPECT_NE(out.find("dB fitted (kept)"), std::string::npos) << out;
    const auto kept = out.find("(kept)");
    EXPECT_NE(out.rfind("edges simply_supported", kept), std::string::npos);
    EXPECT_EQ(out.substr(out.rfind("edges ", kept), 22), "edges simply_supported") << out;
    const scene::Scene f = scene::load_scene(fitted.string());
    EXPECT_EQ(f.plate.edges.left, engine::EdgeKind::simply_supported);
    EXPECT_EQ(f.plate.edges.top, engine::EdgeKind::simply_supported);
}

TEST_F(FitCli, RefusalsWriteNothing)
{
    const std::string nominal = scenes + "inverse.toml";
    const fs::path bench = dir / "bench";
    ASSERT_EQ(run("measure-plan \"" + nominal + "\" -o \"" + bench.string() + "\"").exit_code, 0);
    std::ofstream(bench / "measurements.toml", std::ios::app)
        << "\n[[sensor]]\nposition_m = [0.11, 0.09]\nchannel = 0\nquantity = \"acceleration\"\n";
    // No recording yet: the fit names the file and key, writes no scene.
    const fs::path fitted = dir / "fitted.toml";
    Outcome r = run("fit \"" + nominal + "\" \"" + (bench / "measurements.toml").string() + "\" -o \"" +
                    fitted.string() + "\" -q");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("recording.file"), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
    EXPECT_FALSE(fs::exists(fitted));
    // bench-record needs a panel with fixed exciters.
    r = run("bench-record \"" + scenes + "small.toml\" \"" + (bench / "measurements.toml").string() + "\" -q");
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find("placement = \"fixed\""), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(bench / "rec.wav"));
}
