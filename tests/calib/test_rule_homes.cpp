// Rules calibgen once wrote in several places, each now in one home: the
// home gives what its callers computed before, bit for bit where they did.
#include "engine/plate_operator.h"
#include "io/format.h"
#include "io/read_file.h"
#include "physics/dispersion.h"
#include "physics/material.h"
#include "pipeline/data/tolerance_spec.h"
#include "pipeline/design/finishing.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

using namespace calib;

namespace {

constexpr double pi = std::numbers::pi;

} // namespace

TEST(RuleHomes, FormatIsPrintfWhateverTheLength)
{
    EXPECT_EQ(io::fmt("%g", 0.1), "0.1");
    EXPECT_EQ(io::fmt("T60 %.3g s at %.4g Hz", 0.18, 300.0), "T60 0.18 s at 300 Hz");
    EXPECT_EQ(io::fmt("%.*g", 3, 2.0 / 3), "0.667");
    EXPECT_EQ(io::fmt("crc32:%08lx", 0xabcUL), "crc32:00000abc");
    const std::string wide(300, 'x');
    const std::string f = wide + " %g " + wide;
    char b[1024];
    std::snprintf(b, sizeof b, f.c_str(), 1.5);
    EXPECT_EQ(io::fmt(f.c_str(), 1.5), b); // beyond the first buffer: nothing cut
}

TEST(RuleHomes, ReadFileGivesEveryByteOrNothing)
{
    const std::filesystem::path p = std::filesystem::temp_directory_path() / "calib_rule_homes_read.bin";
    const std::string bytes("a\0b\r\n\xff", 6);
    std::ofstream(p, std::ios::binary) << bytes;
    const std::optional<std::string> got = io::read_file(p.string());
    ASSERT_TRUE(got.has_value());
    EXPECT_EQ(*got, bytes);
    std::filesystem::remove(p);
    EXPECT_FALSE(io::read_file(p.string()).has_value());
}

TEST(RuleHomes, KirchhoffFormsFromKappa)
{
    for (const char *name : {"acrylic", "glass", "steel"}) {
        const physics::Material m = *physics::find_material(name);
        for (double d : {0.0011, 0.002, 0.008})
            for (double f : {150.0, 300.0, 1234.5}) {
                const double kappa = m.kappa(d);
                // As the callers wrote them before (bit for bit).
                EXPECT_EQ(physics::kirchhoff_wavelength_m(kappa, f), 2 * pi * std::sqrt(kappa / (2 * pi * f)));
                EXPECT_EQ(physics::kirchhoff_group_velocity_m_s(kappa, f), 2.0 * std::sqrt(2 * pi * f * kappa));
                EXPECT_EQ(physics::kirchhoff_phase_velocity_m_s(kappa, f), physics::kirchhoff_phase_velocity(m, d, f));
                EXPECT_EQ(physics::kirchhoff_group_velocity_m_s(kappa, f), physics::kirchhoff_group_velocity(m, d, f));
                // lambda = c / f.
                EXPECT_NEAR(physics::kirchhoff_wavelength_m(kappa, f) * f /
                                physics::kirchhoff_phase_velocity_m_s(kappa, f),
                            1.0, 1e-15);
            }
    }
}

TEST(RuleHomes, T60AndDecayRate)
{
    EXPECT_EQ(engine::t60_of_decay_rate_s(12.5), 3 * std::log(10.0) / 12.5);
    EXPECT_EQ(engine::decay_rate_of_t60_1_s(0.18), 3 * std::log(10.0) / 0.18);
    EXPECT_EQ(engine::t60_of_decay_rate_s(1.0), 3 * 2.302585092994046);
    // The loss fitted to two T60s gives them back at their frequencies.
    const double kappa = physics::find_material("acrylic")->kappa(0.002);
    const engine::Loss l = engine::loss_from_t60(kappa, 100, 0.54, 300, 0.18);
    EXPECT_NEAR(engine::t60_of_decay_rate_s(l.decay_rate_1_s(2 * pi * 100, kappa)), 0.54, 1e-12);
    EXPECT_NEAR(engine::t60_of_decay_rate_s(l.decay_rate_1_s(2 * pi * 300, kappa)), 0.18, 1e-12);
}

TEST(RuleHomes, DitherSeedAndDriveOptions)
{
    pipeline::CalibrationInput in;
    in.exciters.seed = 7;
    in.calibration.truncate_fraction = 0.25;
    in.calibration.output_rate_hz = 44100;
    in.calibration.dither = false;
    EXPECT_EQ(pipeline::dither_seed(in, 3), 7u * 1000003u + 3u);
    const pipeline::TimeReversalOptions o = pipeline::drive_options(in, 3);
    EXPECT_EQ(o.dither_seed, 7u * 1000003u + 3u);
    EXPECT_EQ(o.truncate_fraction, 0.25);
    EXPECT_EQ(o.output_rate_hz, 44100);
    EXPECT_FALSE(o.dither);
    EXPECT_EQ(o.taper_s, pipeline::TimeReversalOptions{}.taper_s);
}

TEST(RuleHomes, PanelYoungsPerKelvinIsTheBoxsElseTheMaterials)
{
    const physics::Material acrylic = *physics::find_material("acrylic");
    ASSERT_NE(acrylic.youngs_per_kelvin, 0);
    pipeline::ToleranceSpec box;
    EXPECT_EQ(pipeline::panel_youngs_per_kelvin(nullptr, acrylic), acrylic.youngs_per_kelvin);
    EXPECT_EQ(pipeline::panel_youngs_per_kelvin(&box, acrylic), acrylic.youngs_per_kelvin);
    box.youngs_per_kelvin = 0.0; // stated: 0 is the box's figure, not "unknown"
    EXPECT_EQ(pipeline::panel_youngs_per_kelvin(&box, acrylic), 0.0);
    box.youngs_per_kelvin = -1e-3;
    EXPECT_EQ(pipeline::panel_youngs_per_kelvin(&box, acrylic), -1e-3);
}
