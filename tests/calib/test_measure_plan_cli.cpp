// `calibgen measure-plan` as a lab runs it: a fixed-placement scene gives
// plan.wav (PCM_16, one channel per exciter) and measurements.toml, which the
// reader takes back once sensors and a recording are added; a random
// placement takes its positions from --table; a random placement without a
// table, a bad option or a bad table is refused in one line, nothing written.
#include "scene/measurements.h"
#include "scene/scene.h"
#include "scene/wav_file.h"

#include <gtest/gtest.h>
#include <sndfile.h>
extern "C" {
#include <table_fixture.h>
}

#include "calibgen_run.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

namespace fs = std::filesystem;
using namespace calib;
using calibgen_run::Outcome;
using calibgen_run::read_text;

namespace {

const std::string scenes = std::string(HAPTIC_SOURCE_DIR) + "/tests/calib/scenes/";

class MeasurePlanCli : public calibgen_run::Workdir {
  protected:
    MeasurePlanCli() : Workdir("haptic-measure-plan") {}

    // The refusal's one line, and nothing in `out_dir`.
    void expect_refused(const Outcome &r, const fs::path &out_dir, const std::string &fragment)
    {
        EXPECT_EQ(r.exit_code, 1) << r.err;
        EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
        EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
        EXPECT_FALSE(fs::exists(out_dir)) << "written on refusal: " << out_dir;
    }
};

} // namespace

TEST_F(MeasurePlanCli, FixedPlacementWritesThePlanAndItsToml)
{
    const Outcome r = run("measure-plan \"" + scenes + "inverse.toml\" -o \"" + (dir / "bench").string() + "\"");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    // What was chosen, on the terminal.
    for (const char *word : {"band     150.0 to 4298", "sweep    1.000 s per exciter, set by the 1 s minimum",
                             "gap      0.500 s", "level    -6.0 dBFS", "total    6.25 s"})
        EXPECT_NE(out.find(word), std::string::npos) << word << " not in:\n" << out;
    // plan.wav: PCM_16, 4 channels at the scene's 48 kHz.
    SF_INFO info{};
    SNDFILE *snd = sf_open((dir / "bench" / "plan.wav").c_str(), SFM_READ, &info);
    ASSERT_NE(snd, nullptr);
    sf_close(snd);
    EXPECT_EQ(info.format, SF_FORMAT_WAV | SF_FORMAT_PCM_16);
    EXPECT_EQ(info.channels, 4);
    EXPECT_EQ(info.samplerate, 48000);
    EXPECT_EQ(info.frames, 300000);
    // Nothing else in the directory (no temporary files left).
    std::size_t files = 0;
    for ([[maybe_unused]] const auto &e : fs::directory_iterator(dir / "bench"))
        files++;
    EXPECT_EQ(files, 2u);
    // The toml, with a recording and sensors added, reads back.
    const scene::WavData plan = scene::read_wav((dir / "bench" / "plan.wav").string());
    {
        SF_INFO ri{};
        ri.samplerate = 48000;
        ri.channels = 2;
        ri.format = SF_FORMAT_WAV | SF_FORMAT_PCM_24;
        SNDFILE *w = sf_open((dir / "bench" / "rec.wav").c_str(), SFM_WRITE, &ri);
        ASSERT_NE(w, nullptr);
        std::vector<double> x(plan.frames * 2);
        for (std::size_t n = 0; n < plan.frames; n++) {
            x[2 * n] = 0.5 * plan.at(n, 0) + 0.2 * plan.at(n, 3);
            x[2 * n + 1] = 0.3 * plan.at(n, 1);
        }
        sf_writef_double(w, x.data(), sf_count_t(plan.frames));
        sf_close(w);
    }
    std::string toml = read_text(dir / "bench" / "measurements.toml");
    EXPECT_NE(toml.find("# Scene:   " + scenes + "inverse.toml (crc32:"), std::string::npos) << toml;
    EXPECT_NE(toml.find("start_frames = [12000, 84000, 156000, 228000]"), std::string::npos) << toml;
    toml += "[[sensor]]\nposition_m = [0.15, 0.12]\nchannel = 0\nquantity = \"acceleration\"\n"
            "[[sensor]]\nposition_m = [0.10, 0.20]\nchannel = 1\nquantity = \"displacement\"\n";
    std::ofstream(dir / "bench" / "measurements.toml") << toml;
    const scene::Scene sc = scene::load_scene(scenes + "inverse.toml");
    const scene::Measurements m = scene::load_measurements((dir / "bench" / "measurements.toml").string(), sc);
    EXPECT_EQ(m.start_frames, (std::vector<std::size_t>{12000, 84000, 156000, 228000}));
    EXPECT_EQ(m.sweep_frames(), 48000u);
    EXPECT_EQ(m.segment_frames(), 72000u);
    EXPECT_EQ(m.exciters.size(), 4u);
    EXPECT_EQ(m.exciters[3].y_m, 0.221);
    // Each exciter's segment holds its own sweep only.
    for (std::size_t e = 0; e < 4; e++)
        for (std::size_t c = 0; c < 4; c++) {
            const std::vector<double> seg = plan.channel(c, m.start_frames[e], m.segment_frames());
            double peak = 0;
            for (double v : seg)
                peak = std::max(peak, std::abs(v));
            if (c == e)
                EXPECT_NEAR(peak, std::pow(10.0, -6.0 / 20), 1e-4) << "exciter " << e; // -6 dBFS
            else
                EXPECT_EQ(peak, 0.0) << "exciter " << e << " channel " << c;
        }
}

TEST_F(MeasurePlanCli, RandomPlacementTakesThePositionsFromTheTable)
{
    // A table of 8 channels whose exciters sit inside small.toml's 0.35 m plate.
    table_fixture fx;
    table_fixture_init(&fx, 8, 1, 64, 1);
    for (int c = 0; c < 8; c++) {
        fx.channel_xy[2 * c] = 0.02 + 0.04 * c;
        fx.channel_xy[2 * c + 1] = 0.015;
    }
    haptic_table_error err{};
    ASSERT_EQ(haptic_table_write((dir / "t.htab").c_str(), &fx.spec, &err), 0) << err.message;
    table_fixture_free(&fx);
    const Outcome r = run("measure-plan \"" + scenes + "small.toml\" --table \"" + (dir / "t.htab").string() +
                          "\" --rate 44100 -o \"" + (dir / "bench").string() + "\"");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.err.find("note: "), std::string::npos) << "the table's scene hash differs: " << r.err;
    const std::string toml = read_text(dir / "bench" / "measurements.toml");
    EXPECT_NE(toml.find("positions_m = [[0.02, 0.015], [0.06, 0.015], [0.1, 0.015], [0.14, 0.015], [0.18, 0.015], "
                        "[0.22, 0.015], [0.26, 0.015], [0.3, 0.015]]"),
              std::string::npos)
        << toml;
    EXPECT_NE(toml.find("rate_hz = 44100"), std::string::npos);
    const scene::WavData plan = scene::read_wav((dir / "bench" / "plan.wav").string());
    EXPECT_EQ(plan.channels, 8u);
    EXPECT_EQ(plan.rate_hz, 44100);
}

TEST_F(MeasurePlanCli, RefusesInOneLineAndWritesNothing)
{
    const fs::path out_dir = dir / "bench";
    // A random placement without a table.
    expect_refused(run("measure-plan \"" + scenes + "small.toml\" -o \"" + out_dir.string() + "\""), out_dir,
                   "small.toml: exciters.placement: \"random\": where the exciters are glued is the calibration's "
                   "choice: give --table TABLE.htab");
    // A level above full scale.
    expect_refused(run("measure-plan \"" + scenes + "inverse.toml\" --level-dbfs 3 -o \"" + out_dir.string() + "\""),
                   out_dir, "--level-dbfs: must lie in [-60, 0), got 3");
    // A table for another number of exciters.
    table_fixture fx;
    table_fixture_init(&fx, 3, 1, 64, 1);
    haptic_table_error err{};
    ASSERT_EQ(haptic_table_write((dir / "t3.htab").c_str(), &fx.spec, &err), 0) << err.message;
    table_fixture_free(&fx);
    expect_refused(run("measure-plan \"" + scenes + "small.toml\" --table \"" + (dir / "t3.htab").string() +
                       "\" -o \"" + out_dir.string() + "\""),
                   out_dir, "t3.htab: 3 channels but");
    // A scene without a loss law: the silence could not be sized.
    expect_refused(run("measure-plan \"" + scenes + "effect-finger.toml\" -o \"" + out_dir.string() + "\""), out_dir,
                   "effect-finger.toml: plate.loss: missing");
}
