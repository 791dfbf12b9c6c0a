// A scene file (TOML, SI units) describes one plate and how to simulate it.
// One struct per section, one parse function per section: [plate] and
// [simulation] in scene.cpp, [active_area], [exciters], [foci], [pulse] and
// [calibration] in calibration_sections.cpp, [effects] in effects_section.cpp;
// a new section is a sub-struct here, a parser, a line in the section table.
// Errors are one line naming the file and the key.
#pragma once

#include "engine/effects/effects.h"
#include "engine/plate_operator.h"
#include "engine/simulation.h"
#include "physics/material.h"
#include "pipeline/data/spec.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/data/tolerance_spec.h"

#include <memory>
#include <optional>
#include <string>
#include <string_view>

namespace calib::scene {

// [plate.loss]: T60 (s, amplitude -60 dB) at two frequencies.
struct LossSpec {
    double f1_hz = 0, t60_1_s = 0;
    double f2_hz = 0, t60_2_s = 0;
};

// [plate]
struct PlateSpec {
    double size_x_m = 0;
    double size_y_m = 0;
    double thickness_m = 0;
    physics::Material material;
    engine::Edges edges;
    std::optional<LossSpec> loss;
    // The temperature the plate is calibrated at (the material's values hold
    // there), degrees Celsius: stored in the table for the device's
    // temperature compensation (docs/table-format.md, panel section).
    double temperature_c = 23;
};

// [simulation]
struct SimulationSpec {
    double f_max_hz = 0;                  // highest frequency to resolve
    double points_per_wavelength = 20;    // at f_max (A0, Kirchhoff)
    std::optional<double> grid_spacing_m; // overrides points_per_wavelength
    double courant = 0.95;                // fraction of the stability bound
    std::optional<double> time_step_s;    // forced step (refused beyond the bound)
    engine::Precision precision = engine::Precision::f32;
    int threads = 0; // 0: all
};

struct Scene {
    std::string file; // as given, for messages
    std::string name; // top-level `name = "..."`, default: the file name without .toml
    PlateSpec plate;
    SimulationSpec simulation;
    // The calibration sections (docs/scene-format.md); `calibrate` needs all five.
    std::optional<pipeline::ActiveAreaSpec> active_area;
    std::optional<pipeline::ExcitersSpec> exciters;
    std::optional<pipeline::FociSpec> foci;
    std::optional<pipeline::PulseSpec> pulse;
    std::optional<pipeline::CalibrationSpec> calibration;
    engine::effects::EffectsSpec effects;             // [effects] (docs/scene-format.md); all off when absent
    std::optional<pipeline::ToleranceSpec> tolerance; // [tolerance] (docs/robustness.md)
    std::optional<pipeline::RobustSpec> robust;       // [calibration] robust = { ... }
    bool calibration_sections() const { return active_area && exciters && foci && pulse && calibration; }
};

// Throws SceneError (one line: "file: key: problem").
Scene load_scene(const std::string &path);
Scene parse_scene(std::string_view toml_text, const std::string &file_name);

// The operator and the simulation options a scene asks for: the Kirchhoff
// operator, and with [effects] thick_plate the Mindlin operator too
// (options.thick_plate, options.thick_plate_operator: the simulations then
// run the Mindlin engine). Throws SceneError naming the key (loss that cannot
// be fitted, a forced time step beyond the stability bound, a grid too large,
// a thick plate with free edges or loss).
struct PlateSetup {
    std::shared_ptr<const engine::PlateOperator> plate;
    engine::SimulationOptions options;
};
PlateSetup build_plate(const Scene &scene);
// The grid build_plate uses, without building anything. Throws SceneError
// naming the cell count and the keys for a grid past the engine's limit.
engine::Grid plate_grid(const Scene &scene);

} // namespace calib::scene
