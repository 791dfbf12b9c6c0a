// What a scene's [effects] section asks for (docs/scene-format.md, docs/effects.md).
// Each effect is a self-contained unit: the engine composes it only when it is
// named here, and an effect that is not named is never instantiated (it costs
// nothing: no branch in the bulk loop, no hook call).
#pragma once

#include <optional>

namespace calib::engine::effects {

// A fingertip pressing on the plate at one point, as the parallel
// mass-spring-damper of the fingertip's measured mechanical impedance
// Z(s) = m s + c + k / s (Wiertlewski & Hayward 2012): it adds to the plate the
// force f = -(m w_tt + c w_t + k w) at (x, y).
struct FingerSpec {
    double mass_kg = 0;
    double stiffness_n_m = 0;
    double damping_n_s_m = 0;
    double x_m = 0, y_m = 0;
};

// An inertial electrodynamic exciter: the coil is glued to the plate, the
// magnet (moving mass M) hangs on the suspension (k, c); the coil current i
// pushes plate and magnet apart with Bl i. Into a blocked plate the force is
// F = Bl i M s^2 / (M s^2 + c s + k): a second-order high-pass with
// f0 = sqrt(k / M) / 2 pi and Q = sqrt(k M) / c.
struct ExciterSpec {
    double moving_mass_kg = 0;
    double stiffness_n_m = 0;
    double damping_n_s_m = 0;
    double force_factor_n_a = 1; // Bl (N/A)
    bool precompensate = true;   // drive signals pre-filtered by the inverse within the band
    double max_boost_db = 20;    // cap of the inverse's gain below the band
};

struct EffectsSpec {
    // Frequency-dependent loss. The T60 values live in [plate.loss]; this key
    // only switches it: unset means "on iff [plate.loss] is given".
    std::optional<bool> loss;
    bool thick_plate = false; // Mindlin-type shear + rotary inertia
    std::optional<FingerSpec> finger;
    std::optional<ExciterSpec> exciter;
};

} // namespace calib::engine::effects
