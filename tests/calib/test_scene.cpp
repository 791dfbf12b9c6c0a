// Scene files: a good scene gives the plate it describes; every bad key or
// value is refused with one line naming the file and the key.
#include "scene/scene.h"
#include "scene/toml_fields.h"

#include <gtest/gtest.h>

#include <string>

#include "scene_text.h"

using namespace calib::scene;
using calib::engine::EdgeKind;

namespace {

using scene_text::error_of;
using scene_text::replace;

const char *good = R"(
[plate]
size_m = [0.7, 0.5]
thickness_m = 0.002
material = "acrylic"
edges = { left = "free", right = "clamped", bottom = "simply_supported", top = "free" }
[plate.loss]
frequencies_hz = [100, 1000]
t60_s = [0.2, 0.1]

[simulation]
f_max_hz = 1000
points_per_wavelength = 12
courant = 0.9
precision = "double"
threads = 1
)";

} // namespace

TEST(Scene, GoodSceneGivesThePlateItDescribes)
{
    const Scene s = parse_scene(good, "scene.toml");
    EXPECT_EQ(s.plate.size_x_m, 0.7);
    EXPECT_EQ(s.plate.size_y_m, 0.5);
    EXPECT_EQ(s.plate.material.name, "acrylic");
    EXPECT_EQ(s.plate.edges.left, EdgeKind::free);
    EXPECT_EQ(s.plate.edges.right, EdgeKind::clamped);
    EXPECT_EQ(s.plate.edges.bottom, EdgeKind::simply_supported);
    EXPECT_EQ(s.plate.edges.top, EdgeKind::free);
    ASSERT_TRUE(s.plate.loss);
    EXPECT_EQ(s.plate.loss->t60_2_s, 0.1);
    EXPECT_EQ(s.simulation.precision, calib::engine::Precision::f64);
    const PlateSetup p = build_plate(s);
    // Kirchhoff A0 wavelength of 2 mm acrylic at 1 kHz: kappa = sqrt(D / rho d)
    // = 1.24313 m^2/s (hand-computed), lambda = 2 pi sqrt(kappa / omega) = 88.4 mm;
    // 12 points per wavelength -> h <= 7.365 mm -> 0.7 / 7.365 mm = 95.04,
    // rounded up to 96 intervals (h = 7.292 mm); 0.5 m / h = 68.57 -> 69.
    EXPECT_EQ(p.plate->grid().nx, 96);
    EXPECT_EQ(p.plate->grid().ny, 69);
    EXPECT_NEAR(p.plate->kappa(), 1.24313, 1e-5);
    EXPECT_GT(p.plate->params().loss.sigma0, 0);
    EXPECT_EQ(p.options.courant, 0.9);
}

TEST(Scene, OptionalName)
{
    EXPECT_EQ(parse_scene(std::string("name = \"demo\"\n") + good, "scene.toml").name, "demo");
    EXPECT_EQ(error_of(std::string("name = 3\n") + good), "scene.toml: name: must be a string");
}

TEST(Scene, MaterialAndEdgesInTheirOtherForms)
{
    std::string t = replace(good, "material = \"acrylic\"",
                            "material = { density_kg_m3 = 2700, youngs_pa = 70e9, poisson = 0.33 }");
    t = replace(t, "edges = { left = \"free\", right = \"clamped\", bottom = \"simply_supported\", top = \"free\" }",
                "edges = \"simply_supported\"");
    const Scene s = parse_scene(t, "scene.toml");
    EXPECT_EQ(s.plate.material.density_kg_m3, 2700);
    EXPECT_EQ(s.plate.edges.top, EdgeKind::simply_supported);
    EXPECT_EQ(s.plate.edges.left, EdgeKind::simply_supported);
}

TEST(Scene, BadValuesNameTheKey)
{
    EXPECT_EQ(error_of(replace(good, "thickness_m = 0.002", "thickness_m = -1")),
              "scene.toml: plate.thickness_m: must be > 0, got -1");
    EXPECT_EQ(error_of(replace(good, "thickness_m = 0.002", "thickness_m = \"thin\"")),
              "scene.toml: plate.thickness_m: must be a number, got string");
    EXPECT_EQ(error_of(replace(good, "thickness_m = 0.002\n", "")),
              "scene.toml: plate.thickness_m: missing (required)");
    EXPECT_EQ(error_of(replace(good, "size_m = [0.7, 0.5]", "size_m = [0.7]")),
              "scene.toml: plate.size_m: must be an array of 2 numbers");
    EXPECT_EQ(error_of(replace(good, "material = \"acrylic\"", "material = \"cheese\"")),
              "scene.toml: plate.material: unknown material \"cheese\" (known: acrylic, glass, steel)");
    EXPECT_EQ(error_of(replace(good, "right = \"clamped\"", "right = \"glued\"")),
              "scene.toml: plate.edges.right: unknown edge \"glued\" (known: clamped, simply_supported, free)");
    EXPECT_EQ(error_of(replace(good, "right = \"clamped\", ", "")),
              "scene.toml: plate.edges.right: missing (required; edges given per edge need all four)");
    EXPECT_EQ(error_of(replace(good, "precision = \"double\"", "precision = \"half\"")),
              "scene.toml: simulation.precision: must be \"float\" or \"double\", got \"half\"");
    EXPECT_EQ(error_of(replace(good, "courant = 0.9", "courant = 1.2")),
              "scene.toml: simulation.courant: must lie in (0, 1) (fraction of the stability bound), got 1.2");
    EXPECT_EQ(error_of(replace(good, "t60_s = [0.2, 0.1]", "t60_s = [0.1, 0.2]")),
              "scene.toml: plate.loss: loss: T60 must not grow with frequency (0.1 s at 100 Hz, 0.2 s at 1000 Hz)");
    EXPECT_EQ(error_of(replace(good, "f_max_hz = 1000\n", "")),
              "scene.toml: simulation.f_max_hz: missing (required unless grid_spacing_m is given or the scene has a "
              "[pulse])");
}

TEST(Scene, UnknownKeysAndSectionsAreRefusedWithTheKnownOnes)
{
    EXPECT_EQ(
        error_of(replace(good, "thickness_m = 0.002", "thickness_m = 0.002\ncolour = \"red\"")),
        "scene.toml: plate.colour: unknown key (known: size_m, thickness_m, material, edges, loss, temperature_c)");
    EXPECT_EQ(error_of(std::string(good) + "\n[plate_extra]\nx = 1\n"),
              "scene.toml: plate_extra: unknown section (known: name, plate, simulation, active_area, exciters, foci, "
              "pulse, calibration, effects, tolerance)");
    EXPECT_EQ(error_of(replace(good, "frequencies_hz", "freqs")),
              "scene.toml: plate.loss.freqs: unknown key (known: frequencies_hz, t60_s)");
    EXPECT_EQ(error_of("[plate]\nsize_m = [1, 1]\n"), "scene.toml: plate.thickness_m: missing (required)");
}

TEST(Scene, ForcedStepBeyondTheBoundNamesTheBound)
{
    const std::string e = error_of(replace(good, "courant = 0.9", "time_step_s = 1e-3"));
    EXPECT_EQ(e.rfind("scene.toml: simulation.time_step_s: time step 0.001 s is not below the stability bound ", 0), 0u)
        << e;
    EXPECT_EQ(error_of(replace(good, "courant = 0.9", "time_step_s = 1e-7")), "");
}

TEST(Scene, SyntaxErrorsGiveTheLine)
{
    const std::string e = error_of("[plate]\nsize_m = [0.7, 0.5\n");
    EXPECT_EQ(e.rfind("scene.toml:2:", 0), 0u) << e;
    EXPECT_NE(e.find("TOML syntax error"), std::string::npos) << e;
}

TEST(Scene, MissingFileIsNamed)
{
    try {
        load_scene("/nonexistent/scene.toml");
        FAIL();
    } catch (const SceneError &e) {
        EXPECT_STREQ(e.what(), "/nonexistent/scene.toml: cannot open scene file");
    }
}

#ifdef HAPTIC_SOURCE_DIR
TEST(Scene, ShippedTestScenesLoadAndBuild)
{
    for (const char *name : {"test-small.toml", "test-mixed-edges.toml", "test-acrylic-lossy.toml"}) {
        const std::string path = std::string(HAPTIC_SOURCE_DIR) + "/scenes/" + name;
        EXPECT_NO_THROW(build_plate(load_scene(path))) << path;
    }
}
#endif
