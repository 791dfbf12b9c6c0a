// Which effects a calibration runs with, and why: `calibgen calibrate` prints
// this. An effect the scene leaves out is reported with the estimated error of
// leaving it out at the scene's band and geometry; an effect the scene asks
// for that the band makes negligible is reported as such.
#pragma once

#include "engine/effects/effects.h"
#include "engine/plate_operator.h"

#include <string>
#include <vector>

namespace calib::report {

struct EffectStatus {
    std::string name;           // "loss", "thick_plate", "finger", "exciter"
    bool active = false;        // the simulation composes it
    bool negligible = false;    // the estimate below is under the threshold
    double estimated_error = 0; // relative size of the effect (dimensionless; meaning in `why`)
    std::string why;            // one line
};

// Thresholds: an effect whose estimate is below this relative size is "negligible".
constexpr double negligible_relative = 0.01;

// What the caller's simulation can compose. `calibrate` composes everything:
// loss (kernel variant), the thick plate (Mindlin engine in every
// simulation, calibration and verification), the finger (in the verification
// runs only: it presses during playback) and the exciter (blocked-force
// filter on the drive + pre-compensation of the signals). The defaults (false)
// describe a bare Kirchhoff simulation.
struct EffectSupport {
    bool thick_plate = false;
    bool finger = false;
};

// plate: the operator's parameters (loss already fitted or zero);
// f_lo_hz, f_hi_hz: the band the calibration uses (pulse band).
std::vector<EffectStatus> assess_effects(const engine::effects::EffectsSpec &spec, const engine::PlateParams &plate,
                                         double f_lo_hz, double f_hi_hz, const EffectSupport &support = {});

// One line per effect: "effect <name>: <why>".
std::vector<std::string> describe_effects(const std::vector<EffectStatus> &status);

// Kirchhoff-vs-exact A0 relative phase-velocity error at f (what leaving out
// the thick-plate correction costs).
double kirchhoff_phase_error(const physics::Material &m, double thickness_m, double f_hz);

} // namespace calib::report
