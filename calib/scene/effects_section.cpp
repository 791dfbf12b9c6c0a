#include "scene/effects_section.h"

#include "engine/effects/exciter.h"
#include "scene/scene.h"

#include <cmath>
#include <stdexcept>

namespace calib::scene {

namespace {

double non_negative(const Fields &f, std::string_view key, double fallback)
{
    const std::optional<double> v = f.number(key);
    if (!v)
        return fallback;
    if (!(*v >= 0) || !std::isfinite(*v))
        f.fail(key, "must be >= 0, got " + format_number(*v));
    return *v;
}

} // namespace

engine::effects::EffectsSpec parse_effects(const Fields &f, const PlateSpec &plate)
{
    engine::effects::EffectsSpec e;
    e.loss = f.boolean("loss");
    if (e.loss && *e.loss && !plate.loss)
        f.fail("loss", "true needs [plate.loss] (frequencies_hz, t60_s) to say how much");
    if (const auto t = f.boolean("thick_plate"))
        e.thick_plate = *t;
    if (auto ft = f.table("finger", {"mass_kg", "stiffness_n_m", "damping_n_s_m", "position_m"})) {
        engine::effects::FingerSpec s;
        s.mass_kg = non_negative(*ft, "mass_kg", 0);
        s.stiffness_n_m = non_negative(*ft, "stiffness_n_m", 0);
        s.damping_n_s_m = non_negative(*ft, "damping_n_s_m", 0);
        if (s.mass_kg == 0 && s.stiffness_n_m == 0 && s.damping_n_s_m == 0)
            ft->fail("mass_kg", "a finger needs at least one of mass_kg, stiffness_n_m, damping_n_s_m > 0");
        const auto pos = ft->numbers("position_m", 2);
        if (!pos)
            ft->fail("position_m", "missing ([x, y] in metres)");
        s.x_m = (*pos)[0];
        s.y_m = (*pos)[1];
        if (!(s.x_m >= 0 && s.x_m <= plate.size_x_m && s.y_m >= 0 && s.y_m <= plate.size_y_m))
            ft->fail("position_m", "[" + format_number(s.x_m) + ", " + format_number(s.y_m) +
                                       "] is off the plate [0, " + format_number(plate.size_x_m) + "] x [0, " +
                                       format_number(plate.size_y_m) + "]");
        e.finger = s;
    }
    if (auto xt = f.table("exciter", {"moving_mass_kg", "stiffness_n_m", "damping_n_s_m", "force_factor_n_a",
                                      "precompensate", "max_boost_db"})) {
        engine::effects::ExciterSpec s;
        s.moving_mass_kg = xt->required_positive("moving_mass_kg");
        s.stiffness_n_m = non_negative(*xt, "stiffness_n_m", 0);
        if (!xt->has("stiffness_n_m"))
            xt->fail("stiffness_n_m", "missing (suspension stiffness, N/m)");
        s.damping_n_s_m = non_negative(*xt, "damping_n_s_m", 0);
        if (!xt->has("damping_n_s_m"))
            xt->fail("damping_n_s_m", "missing (mechanical damping, N s/m)");
        s.force_factor_n_a = xt->positive("force_factor_n_a").value_or(1.0);
        if (const auto p = xt->boolean("precompensate"))
            s.precompensate = *p;
        s.max_boost_db = non_negative(*xt, "max_boost_db", s.max_boost_db);
        if (s.max_boost_db > 60)
            xt->fail("max_boost_db", "must lie in [0, 60], got " + format_number(s.max_boost_db));
        e.exciter = s;
    }
    return e;
}

} // namespace calib::scene
