#include "model/error_model.h"

#include "engine/plate_operator.h"
#include "physics/dispersion.h"
#include "pipeline/signal/pulse.h"
#include "io/format.h"

#include <cmath>
#include <cstdio>
#include <numbers>
#include <stdexcept>
#include <string>

namespace calib::model {

namespace {

constexpr double pi = std::numbers::pi;

using io::fmt;

} // namespace

double scene_f_max_hz(const scene::Scene &s)
{
    if (s.simulation.f_max_hz > 0)
        return s.simulation.f_max_hz;
    if (s.pulse)
        return pipeline::pulse_max_frequency_hz(*s.pulse);
    throw std::invalid_argument(s.file + ": simulation.f_max_hz: needed for an accuracy target");
}

double predicted_phase_error(const physics::Material &m, double thickness_m, double f_hz, double h_m,
                             double time_step_s)
{
    if (!(thickness_m > 0) || !(f_hz > 0) || !(m.kappa(thickness_m) > 0))
        throw std::invalid_argument("accuracy: needs a positive thickness, frequency and bending stiffness");
    const double kappa = m.kappa(thickness_m);
    const double mu = kappa * time_step_s / (h_m * h_m);
    const double w = 2 * pi * f_hz;
    const double s = std::sin(w * time_step_s / 2) / (2 * mu);
    if (!(s > 0 && s <= 1))
        return NAN; // f beyond what the grid can carry
    const double beta = 2 / h_m * std::asin(std::sqrt(s));
    return (w / beta) / physics::a0_phase_velocity(m, thickness_m, f_hz) - 1;
}

Choice choose_points_per_wavelength(const scene::Scene &s, double target)
{
    const double f = scene_f_max_hz(s);
    const double kappa = s.plate.material.kappa(s.plate.thickness_m);
    const double lambda = physics::kirchhoff_wavelength_m(kappa, f);
    auto choice_at = [&](double N) {
        Choice c;
        c.points_per_wavelength = N;
        c.h_m = engine::make_grid(s.plate.size_x_m, s.plate.size_y_m, lambda / N).h;
        c.effective_ppw = lambda / c.h_m;
        const double k = s.simulation.courant * c.h_m * c.h_m / (4 * kappa); // interior stability bound
        c.predicted_error = predicted_phase_error(s.plate.material, s.plate.thickness_m, f, c.h_m, k);
        return c;
    };
    constexpr double N_max = 80, step = 0.25;
    const double floor_err = choice_at(N_max).predicted_error;
    if (!(std::abs(floor_err) <= target))
        throw std::invalid_argument(s.file + ": calibration.accuracy: " + fmt("%g", target) +
                                    " is not reachable: the error is still " + fmt("%.3g", std::abs(floor_err)) +
                                    " at 80 points per wavelength (Kirchhoff model vs exact A0 at " + fmt("%.0f", f) +
                                    " Hz)");
    Choice c = choice_at(N_max);
    for (double N = N_max; N >= 4; N -= step) {
        const Choice here = choice_at(N);
        if (!(std::abs(here.predicted_error) <= target))
            break;
        c = here;
    }
    return c;
}

std::optional<Choice> apply_accuracy_target(scene::Scene &s)
{
    if (!s.calibration || !s.calibration->accuracy)
        return std::nullopt;
    Choice c = choose_points_per_wavelength(s, *s.calibration->accuracy);
    s.simulation.f_max_hz = scene_f_max_hz(s);
    s.simulation.points_per_wavelength = c.points_per_wavelength;
    s.simulation.grid_spacing_m.reset();
    return c;
}

} // namespace calib::model
