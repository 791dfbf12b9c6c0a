// What a calibration is given (a scene's plate, simulation options and asks:
// CalibrationInput) and what follows from it alone, before anything runs:
// the radius the verdict judges beyond, whether the transfer matrix holds,
// the options of every simulation, the band where exciters may go, the
// scene's identity. The scene parser fills it (scene/calibration_input.h);
// every stage reads it.
#pragma once
#include "engine/effects/effects.h"
#include "engine/plate_operator.h"
#include "engine/simulation.h"
#include "pipeline/data/geometry.h"
#include "pipeline/data/spec.h"
#include "pipeline/data/tolerance_spec.h"
#include "pipeline/signal/pulse.h"

#include <cstddef>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace calib::pipeline {

struct CalibrationInput {
    std::string scene_name;
    std::string scene_hash; // "crc32:..." of the scene file bytes
    std::shared_ptr<const engine::PlateOperator> plate;
    engine::SimulationOptions simulation;
    ActiveAreaSpec active;
    ExcitersSpec exciters;
    FociSpec foci;
    PulseSpec pulse;
    CalibrationSpec calibration;
    engine::effects::EffectsSpec effects;   // [effects]; the exciter model acts here (docs/effects.md)
    std::optional<ToleranceSpec> tolerance; // [tolerance]: verify over the box (docs/robustness.md)
    std::optional<RobustSpec> robust;       // [calibration] robust: design over an ensemble
    // The radius beyond which a focus's surroundings are judged (the whole
    // area, the other foci, the control points): lambda/2 at the pulse
    // centre on the scene's plate (0: from `plate`). A perturbed plate
    // (robustness/tolerance.h) keeps its scene's, so every plate of a tolerance box is
    // held to the same area in millimetres: a panel whose waves are 0.75 %
    // slower is not judged 0.6 mm closer to the focus.
    double lambda_half_m = 0;
    double plate_temperature_c = 23; // [plate] temperature_c: the table's panel section
};

// Progress of long stages (stage name, items done, items total).
using ProgressFn = std::function<void(const std::string &stage, size_t done, size_t total)>;

// The judged radius: in.lambda_half_m, or lambda/2 (Kirchhoff A0) at the
// pulse centre on in.plate.
double judged_lambda_half_m(const CalibrationInput &in);

// Whether a scene's plate is linear and time-invariant during playback (H
// holds): every effect but the finger.
bool transfer_holds(const CalibrationInput &in);

// The options of every simulation of a calibration: one core each (they run
// in parallel), the Mindlin engine when the scene asks for the thick plate.
engine::SimulationOptions single_core_options(const CalibrationInput &in);

// The exciter band of the scene's plate and active area.
Band band_of(const CalibrationInput &in);

// CRC-32 (zlib) of the scene file bytes, as "crc32:<8 hex>": identifies the
// scene a table came from (provenance, not security).
std::string scene_hash(const std::string &bytes);

} // namespace calib::pipeline
