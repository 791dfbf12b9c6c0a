// What a grid costs in accuracy: the phase-velocity error of the plate
// scheme at f_max, predicted from its discrete dispersion relation, and the
// cheapest grid that meets a target (`[calibration] accuracy`).
// docs/ACCURACY.md has the method and how it compares with measurement.
#pragma once
#include "physics/material.h"
#include "scene/scene.h"

#include <optional>

namespace calib::model {

// The 13-point scheme with leapfrog along a grid axis satisfies
// sin(omega k / 2) = 2 mu sin^2(beta h / 2), mu = kappa k / h^2: solved for
// beta at omega = 2 pi f, its phase velocity omega / beta against the exact
// A0 speed (so the Kirchhoff-vs-Lamb model error is included). NaN when f is
// beyond what the grid carries.
double predicted_phase_error(const physics::Material &m, double thickness_m, double f_hz, double h_m,
                             double time_step_s);

// The highest frequency the scene's grid is built for: simulation.f_max_hz,
// else the pulse's highest significant frequency. Throws naming the key.
double scene_f_max_hz(const scene::Scene &s);

// The cheapest points-per-wavelength (scene's precision and Courant factor)
// whose predicted |error| at f_max is <= target, and stays so for every finer
// grid up to 80 points per wavelength. Throws std::invalid_argument naming
// calibration.accuracy when even that is not enough (the Kirchhoff model error).
struct Choice {
    double points_per_wavelength = 0; // as the scene asks (nominal)
    double effective_ppw = 0;         // lambda / h of the grid make_grid builds (h divides the plate)
    double h_m = 0;
    double predicted_error = 0;
};
Choice choose_points_per_wavelength(const scene::Scene &scene, double target);
// Applies calibration.accuracy (if set) to scene.simulation; returns the choice.
std::optional<Choice> apply_accuracy_target(scene::Scene &scene);

} // namespace calib::model
