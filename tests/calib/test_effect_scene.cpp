// [effects] in a scene: every key parsed, every bad key or value refused with
// one line naming the file and the key; effects absent are off and cost
// nothing; the effect report names what is on and what leaving out costs.
#include "report/effects_report.h"
#include "physics/dispersion.h"
#include "physics/material.h"
#include "scene/scene.h"
#include "scene/toml_fields.h"

#include <gtest/gtest.h>

#include <string>

#include "scene_text.h"

using namespace calib::scene;
using namespace calib::engine::effects;
using namespace calib::report;

namespace {

using scene_text::error_of;
using scene_text::replace;

const std::string plate = R"(
[plate]
size_m = [0.5, 0.4]
thickness_m = 0.002
material = "glass"
edges = "simply_supported"
[plate.loss]
frequencies_hz = [100, 1000]
t60_s = [0.2, 0.1]
[simulation]
f_max_hz = 1000
)";

const std::string effects = R"(
[effects]
loss = true
thick_plate = true
[effects.finger]
mass_kg = 0.004
stiffness_n_m = 1500
damping_n_s_m = 0.8
position_m = [0.2, 0.15]
[effects.exciter]
moving_mass_kg = 0.03
stiffness_n_m = 1.0e5
damping_n_s_m = 25
force_factor_n_a = 3.2
precompensate = false
max_boost_db = 12
)";

} // namespace

TEST(EffectScene, EveryKeyIsRead)
{
    const Scene s = parse_scene(plate + effects, "scene.toml");
    const EffectsSpec &e = s.effects;
    ASSERT_TRUE(e.loss.has_value());
    EXPECT_TRUE(*e.loss);
    EXPECT_TRUE(e.thick_plate);
    ASSERT_TRUE(e.finger.has_value());
    EXPECT_EQ(e.finger->mass_kg, 0.004);
    EXPECT_EQ(e.finger->stiffness_n_m, 1500);
    EXPECT_EQ(e.finger->damping_n_s_m, 0.8);
    EXPECT_EQ(e.finger->x_m, 0.2);
    EXPECT_EQ(e.finger->y_m, 0.15);
    ASSERT_TRUE(e.exciter.has_value());
    EXPECT_EQ(e.exciter->moving_mass_kg, 0.03);
    EXPECT_EQ(e.exciter->stiffness_n_m, 1.0e5);
    EXPECT_EQ(e.exciter->damping_n_s_m, 25);
    EXPECT_EQ(e.exciter->force_factor_n_a, 3.2);
    EXPECT_FALSE(e.exciter->precompensate);
    EXPECT_EQ(e.exciter->max_boost_db, 12);
}

TEST(EffectScene, AbsentSectionMeansEverythingOffButPlateLoss)
{
    const Scene s = parse_scene(plate, "scene.toml");
    EXPECT_FALSE(s.effects.loss.has_value());
    EXPECT_FALSE(s.effects.thick_plate);
    EXPECT_FALSE(s.effects.finger);
    EXPECT_FALSE(s.effects.exciter);
    EXPECT_TRUE(build_plate(s).plate->params().loss.active()); // [plate.loss] keeps working
    const Scene off = parse_scene(plate + "[effects]\nloss = false\n", "scene.toml");
    EXPECT_FALSE(build_plate(off).plate->params().loss.active());
}

TEST(EffectScene, BadKeysAndValuesAreRefusedNamingTheKey)
{
    const std::string all = plate + effects;
    const std::pair<std::string, std::string> cases[] = {
        {replace(all, "loss = true", "loss = 1"), "scene.toml: effects.loss: must be true or false"},
        {replace(all, "thick_plate = true", "thick = true"), "scene.toml: effects.thick: unknown key"},
        {replace(all, "mass_kg = 0.004", "mass_kg = -0.004"), "scene.toml: effects.finger.mass_kg: must be >= 0"},
        {replace(all, "position_m = [0.2, 0.15]", "position_m = [0.2, 0.45]"),
         "scene.toml: effects.finger.position_m: [0.2, 0.45] is off the plate"},
        {replace(all, "position_m = [0.2, 0.15]", ""), "scene.toml: effects.finger.position_m: missing"},
        {replace(all, "moving_mass_kg = 0.03", "moving_mass_kg = 0"), "scene.toml: effects.exciter.moving_mass_kg:"},
        {replace(all, "stiffness_n_m = 1.0e5", ""), "scene.toml: effects.exciter.stiffness_n_m: missing"},
        {replace(all, "max_boost_db = 12", "max_boost_db = 100"),
         "scene.toml: effects.exciter.max_boost_db: must lie in"},
        {replace(all, "precompensate = false", "precompensate = \"no\""),
         "scene.toml: effects.exciter.precompensate: must be true or false"},
        {replace(all, "[plate.loss]\nfrequencies_hz = [100, 1000]\nt60_s = [0.2, 0.1]\n", ""),
         "scene.toml: effects.loss: true needs [plate.loss]"},
    };
    for (const auto &[text, expected] : cases) {
        const std::string err = error_of(text);
        EXPECT_EQ(err.rfind(expected, 0), 0u) << "got: " << err << "\nexpected: " << expected;
        EXPECT_EQ(err.find('\n'), std::string::npos) << err;
    }
}

TEST(EffectReport, ThickPlateNegligibleAtLowFdAndFlaggedAtHighFd)
{
    calib::engine::PlateParams p;
    p.size_x_m = 0.3;
    p.size_y_m = 0.2;
    p.material = calib::physics::material_from_elastic(2500, 70e9, 0.22, "glass");
    EffectsSpec none;
    // 2 mm glass, 300 Hz (f*d = 0.6 kHz mm): Kirchhoff error well below 1 %.
    p.thickness_m = 0.002;
    auto r = assess_effects(none, p, 100, 300);
    ASSERT_EQ(r.size(), 4u);
    EXPECT_EQ(r[1].name, "thick_plate");
    EXPECT_FALSE(r[1].active);
    EXPECT_TRUE(r[1].negligible) << r[1].why;
    // 8 mm glass, 30 kHz (ultrasonic haptics): several % (the exact A0 is the truth).
    p.thickness_m = 0.008;
    r = assess_effects(none, p, 20000, 30000);
    EXPECT_FALSE(r[1].negligible) << r[1].why;
    const double cK = calib::physics::kirchhoff_phase_velocity(p.material, 0.008, 30000);
    const double cA = calib::physics::a0_phase_velocity(p.material, 0.008, 30000);
    EXPECT_NEAR(r[1].estimated_error, cK / cA - 1, 1e-12);
    EXPECT_GT(r[1].estimated_error, 0.04);
    EXPECT_NE(r[1].why.find("NOT negligible"), std::string::npos) << r[1].why;
    // Loss off: says T60 is infinite.
    EXPECT_FALSE(r[0].active);
    EXPECT_NE(r[0].why.find("T60 assumed infinite"), std::string::npos) << r[0].why;
}

TEST(EffectReport, FingerMassRatioUnderAWavelengthSquared)
{
    calib::engine::PlateParams p;
    p.size_x_m = 0.3;
    p.size_y_m = 0.2;
    p.thickness_m = 0.002;
    p.material = calib::physics::material_from_elastic(2500, 70e9, 0.22, "glass");
    EffectsSpec e;
    e.finger = FingerSpec{0.005, 0, 0, 0.1, 0.1};
    // Where the simulation cannot compose the finger, the report says so...
    auto r = assess_effects(e, p, 100, 300);
    EXPECT_FALSE(r[2].active);
    EXPECT_NE(r[2].why.find("NOT composed"), std::string::npos) << r[2].why;
    // ...a simulation that can, runs it.
    r = assess_effects(e, p, 100, 300, EffectSupport{false, true});
    EXPECT_TRUE(r[2].active);
    const double lambda = calib::physics::a0_wavelength(p.material, 0.002, 300);
    EXPECT_NEAR(r[2].estimated_error, 0.005 / (2500 * 0.002 * lambda * lambda), 1e-12);
}
