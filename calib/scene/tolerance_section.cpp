#include "scene/tolerance_section.h"

#include "scene/scene.h"

#include <haptic_table.h>

#include <cmath>

namespace calib::scene {

namespace {

// A relative half-width: >= 0, and below 1 so that the low end stays positive.
double half_width(const Fields &f, std::string_view key, const std::string &what, double nominal, const char *unit,
                  double unit_scale)
{
    auto v = f.number(key);
    if (!v)
        return 0;
    if (!(*v >= 0 && std::isfinite(*v)))
        f.fail(key, "must be >= 0 (a relative half-width), got " + format_number(*v));
    if (*v >= 1)
        f.fail(key, format_number(*v) + " makes " + what + " " + format_number((1 - *v) * nominal * unit_scale) + " " +
                        unit + " at the low end (a plate needs it > 0)");
    return *v;
}

// An array of positive numbers, any length >= 1.
std::vector<double> positive_list(const Fields &f, std::string_view key)
{
    const toml::node *n = f.node(key);
    const toml::array *a = n ? n->as_array() : nullptr;
    if (!a || a->empty())
        f.fail(key, "must be a non-empty array of numbers > 0");
    std::vector<double> v;
    for (const toml::node &e : *a) {
        auto x = e.value<double>();
        if (!x || !(*x > 0) || !std::isfinite(*x))
            f.fail(key, "must be a non-empty array of numbers > 0");
        v.push_back(*x);
    }
    return v;
}

} // namespace

pipeline::ToleranceSpec parse_tolerance(const Fields &f, const PlateSpec &plate)
{
    pipeline::ToleranceSpec t;
    t.youngs_rel = half_width(f, "E_rel", "Young's modulus", plate.material.youngs_pa, "GPa", 1e-9);
    t.density_rel = half_width(f, "rho_rel", "the density", plate.material.density_kg_m3, "kg/m^3", 1);
    t.thickness_rel = half_width(f, "thickness_rel", "the thickness", plate.thickness_m, "mm", 1e3);
    if (auto l = f.numbers("loss", 2)) {
        const double lo = (*l)[0], hi = (*l)[1];
        if (!(lo > 0 && hi >= lo && std::isfinite(hi)))
            f.fail("loss", "must be [min, max] loss factors with 0 < min <= max, got [" + format_number(lo) + ", " +
                               format_number(hi) + "]");
        t.loss_min = lo;
        t.loss_max = hi;
    }
    if (f.has("loss_scale"))
        t.loss_scale = positive_list(f, "loss_scale");
    if (auto v = f.number("exciter_position_m")) {
        if (!(*v >= 0 && std::isfinite(*v)))
            f.fail("exciter_position_m", "must be >= 0 (metres), got " + format_number(*v));
        t.exciter_position_m = *v;
    }
    if (auto v = f.number("E_per_k")) {
        if (!(std::abs(*v) <= HAPTIC_TABLE_PANEL_MAX_YOUNGS_PER_K))
            f.fail("E_per_k",
                   "must be a relative change of E per kelvin within +-0.05 (5 %/K), got " + format_number(*v));
        t.youngs_per_kelvin = *v;
    }
    if (auto v = f.number("temperature_k")) {
        if (!(*v >= 0 && std::isfinite(*v)))
            f.fail("temperature_k", "must be >= 0 (kelvin either side), got " + format_number(*v));
        const double coef = pipeline::panel_youngs_per_kelvin(&t, plate.material);
        if (!(1 - std::abs(coef) * *v > 0))
            f.fail("temperature_k",
                   format_number(*v) + " K at dE/E/dT = " + format_number(coef) + " per K makes Young's modulus <= 0");
        t.temperature_k = *v;
    }
    if (auto b = f.boolean("speed_compensation"))
        t.speed_compensation = *b;
    if (auto n = f.integer("random_cases")) {
        if (*n < 0 || *n > 10000)
            f.fail("random_cases", "must lie in [0, 10000], got " + std::to_string(*n));
        t.random_cases = static_cast<unsigned>(*n);
    }
    if (auto s = f.integer("seed")) {
        if (*s < 0)
            f.fail("seed", "must be >= 0, got " + std::to_string(*s));
        t.seed = static_cast<uint64_t>(*s);
    }
    return t;
}

pipeline::RobustSpec parse_robust(const Fields &f)
{
    auto r = f.table("robust", {"loss", "E_scale", "level"});
    if (!r)
        f.fail("robust", "must be a table { loss = [...], E_scale = [...], level = \"target\" | \"margin\" }");
    pipeline::RobustSpec spec;
    if (auto level = r->string("level")) {
        if (*level != "target" && *level != "margin")
            r->fail("level", "must be \"target\" (the scene's amplitude) or \"margin\", got \"" + *level + "\"");
        spec.margin_level = *level == "margin";
    }
    if (r->has("loss"))
        spec.loss = positive_list(*r, "loss");
    if (r->has("E_scale"))
        spec.youngs_scale = positive_list(*r, "E_scale");
    if (spec.loss.empty() && spec.youngs_scale.empty())
        f.fail("robust", "names no ensemble: give loss = [loss factors] and/or E_scale = [scalings]");
    return spec;
}

} // namespace calib::scene
