#include "scene/scene.h"

#include "scene/calibration_sections.h"
#include "scene/effects_section.h"
#include "scene/tolerance_section.h"
#include "scene/toml_fields.h"

#include "engine/mindlin/mindlin_operator.h"
#include "io/read_file.h"
#include "physics/dispersion.h"

#include <haptic_table.h>

#include <filesystem>

#include <cmath>
#include <cstdio>
#include <sstream>

namespace calib::scene {

namespace {

engine::EdgeKind parse_edge_kind(const Fields &f, std::string_view key, const std::string &word)
{
    if (word == "clamped")
        return engine::EdgeKind::clamped;
    if (word == "simply_supported")
        return engine::EdgeKind::simply_supported;
    if (word == "free")
        return engine::EdgeKind::free;
    f.fail(key, "unknown edge \"" + word + "\" (known: clamped, simply_supported, free)");
}

physics::Material parse_material(const Fields &plate)
{
    if (!plate.has("material"))
        plate.fail("material", "missing (required): a name (" + physics::known_material_names() +
                                   ") or a table {density_kg_m3, youngs_pa, poisson}");
    if (plate.node("material")->is_string()) {
        const auto name = plate.string("material");
        if (auto m = physics::find_material(*name))
            return *m;
        plate.fail("material", "unknown material \"" + *name + "\" (known: " + physics::known_material_names() + ")");
    }
    auto t = plate.table("material", {"name", "density_kg_m3", "youngs_pa", "poisson"});
    if (!t)
        plate.fail("material", "must be a name or a table");
    const double rho = t->required_positive("density_kg_m3");
    const double e = t->required_positive("youngs_pa");
    const double nu = t->required_number("poisson");
    if (!(nu > -1 && nu < 0.5))
        t->fail("poisson", "must lie in (-1, 0.5), got " + format_number(nu));
    return physics::material_from_elastic(rho, e, nu, t->string("name").value_or("custom"));
}

engine::Edges parse_edges(const Fields &plate)
{
    if (!plate.has("edges"))
        plate.fail("edges", "missing (required): one of clamped, simply_supported, free, or a table "
                            "{left, right, bottom, top}");
    if (plate.node("edges")->is_string())
        return engine::Edges::all(parse_edge_kind(plate, "edges", *plate.string("edges")));
    auto t = plate.table("edges", {"left", "right", "bottom", "top"});
    if (!t)
        plate.fail("edges", "must be a string or a table");
    engine::Edges e;
    auto one = [&](const char *key) {
        auto w = t->string(key);
        if (!w)
            t->fail(key, "missing (required; edges given per edge need all four)");
        return parse_edge_kind(*t, key, *w);
    };
    e.left = one("left");
    e.right = one("right");
    e.bottom = one("bottom");
    e.top = one("top");
    return e;
}

void parse_plate(const toml::table &t, Scene &scene)
{
    Fields f(t, scene.file, "plate", {"size_m", "thickness_m", "material", "edges", "loss", "temperature_c"});
    PlateSpec &p = scene.plate;
    auto size = f.numbers("size_m", 2);
    if (!size)
        f.fail("size_m", "missing (required): [Lx, Ly] in metres");
    for (double v : *size)
        if (!(v > 0 && std::isfinite(v)))
            f.fail("size_m", "both sizes must be > 0, got " + format_number(v));
    p.size_x_m = (*size)[0];
    p.size_y_m = (*size)[1];
    p.thickness_m = f.required_positive("thickness_m");
    if (auto v = f.number("temperature_c")) {
        if (!(*v >= HAPTIC_TABLE_PANEL_MIN_TEMPERATURE_C && *v <= HAPTIC_TABLE_PANEL_MAX_TEMPERATURE_C))
            f.fail("temperature_c", "must lie in [-100, 300] degrees C, got " + format_number(*v));
        p.temperature_c = *v;
    }
    p.material = parse_material(f);
    p.edges = parse_edges(f);
    if (auto loss = f.table("loss", {"frequencies_hz", "t60_s"})) {
        auto fr = loss->numbers("frequencies_hz", 2);
        auto t60 = loss->numbers("t60_s", 2);
        if (!fr)
            loss->fail("frequencies_hz", "missing (required): [f1, f2] in Hz");
        if (!t60)
            loss->fail("t60_s", "missing (required): [T60 at f1, T60 at f2] in seconds");
        for (double v : *fr)
            if (!(v > 0))
                loss->fail("frequencies_hz", "must be > 0, got " + format_number(v));
        for (double v : *t60)
            if (!(v > 0))
                loss->fail("t60_s", "must be > 0, got " + format_number(v));
        if ((*fr)[0] == (*fr)[1])
            loss->fail("frequencies_hz", "the two frequencies must differ");
        p.loss = LossSpec{(*fr)[0], (*t60)[0], (*fr)[1], (*t60)[1]};
    }
}

void parse_simulation(const toml::table &t, Scene &scene)
{
    Fields f(t, scene.file, "simulation",
             {"f_max_hz", "points_per_wavelength", "grid_spacing_m", "courant", "time_step_s", "precision", "threads"});
    SimulationSpec &s = scene.simulation;
    if (auto v = f.positive("grid_spacing_m"))
        s.grid_spacing_m = *v;
    if (s.grid_spacing_m && f.has("points_per_wavelength"))
        f.fail("points_per_wavelength", "give either points_per_wavelength or grid_spacing_m, not both");
    if (auto v = f.positive("f_max_hz"))
        s.f_max_hz = *v; // else: from [pulse], or refused after all sections are read
    if (auto v = f.positive("points_per_wavelength")) {
        if (*v < 4)
            f.fail("points_per_wavelength", "must be >= 4, got " + format_number(*v));
        s.points_per_wavelength = *v;
    }
    if (auto v = f.number("courant")) {
        if (!(*v > 0 && *v < 1))
            f.fail("courant", "must lie in (0, 1) (fraction of the stability bound), got " + format_number(*v));
        s.courant = *v;
    }
    if (auto v = f.positive("time_step_s"))
        s.time_step_s = *v;
    if (auto p = f.string("precision")) {
        if (*p == "float")
            s.precision = engine::Precision::f32;
        else if (*p == "double")
            s.precision = engine::Precision::f64;
        else
            f.fail("precision", "must be \"float\" or \"double\", got \"" + *p + "\"");
    }
    if (auto n = f.integer("threads")) {
        if (*n < 0 || *n > 1024)
            f.fail("threads", "must lie in [0, 1024] (0: all), got " + std::to_string(*n));
        s.threads = int(*n);
    }
}

// The sections a scene may have, in the order they are parsed.
struct Section {
    const char *name;
    bool required;
    void (*parse)(const toml::table &, Scene &);
};
void parse_active_area_section(const toml::table &t, Scene &scene)
{
    scene.active_area =
        parse_active_area(Fields(t, scene.file, "active_area", {"rect_m", "frame_margin_m", "clearance_m"}));
}

void parse_exciters_section(const toml::table &t, Scene &scene)
{
    scene.exciters =
        parse_exciters(Fields(t, scene.file, "exciters",
                              {"count", "placement", "criterion", "seed", "min_spacing_m", "force_full_scale_n",
                               "positions_m", "site_spacing_m", "restarts", "iterations", "verdict_rounds",
                               "contrast_window", "placement_foci", "force_gains"}));
}

void parse_foci_section(const toml::table &t, Scene &scene)
{
    Fields f(t, scene.file, "foci", {"grid", "pitch_m", "points_m", "ids"});
    for (const char *key : {"grid", "pitch_m"})
        if (f.has(key) && !scene.active_area)
            f.fail(key, "needs an [active_area] to fill (or give points_m)");
    scene.foci = parse_foci(f, scene.active_area.value_or(pipeline::ActiveAreaSpec{}));
}

void parse_pulse_section(const toml::table &t, Scene &scene)
{
    scene.pulse = parse_pulse(Fields(t, scene.file, "pulse", {"shape", "centre_hz", "cycles", "amplitude_m"}));
}

void parse_calibration_section(const toml::table &t, Scene &scene)
{
    const Fields f(t, scene.file, "calibration",
                   {"window_s", "truncate_fraction", "output_rate_hz", "sample_format", "threshold_m", "dither",
                    "accuracy", "verify_tail_s", "method", "exciter_gains", "lead_time_s", "regularization",
                    "active_damping_s", "robust"});
    scene.calibration = parse_calibration(f);
    if (f.has("robust")) // with either method (pipeline/robustness/robust_design.h)
        scene.robust = parse_robust(f);
}

void parse_tolerance_section(const toml::table &t, Scene &scene)
{
    scene.tolerance =
        parse_tolerance(Fields(t, scene.file, "tolerance",
                               {"E_rel", "rho_rel", "thickness_rel", "loss", "loss_scale", "exciter_position_m",
                                "temperature_k", "E_per_k", "speed_compensation", "random_cases", "seed"}),
                        scene.plate);
}

void parse_effects_section(const toml::table &t, Scene &scene)
{
    scene.effects =
        parse_effects(Fields(t, scene.file, "effects", {"loss", "thick_plate", "finger", "exciter"}), scene.plate);
}

// The order matters where a section uses another: [foci] grids divide the active area.
constexpr Section sections[] = {
    {"plate", true, parse_plate},
    {"simulation", false, parse_simulation},
    {"active_area", false, parse_active_area_section},
    {"exciters", false, parse_exciters_section},
    {"foci", false, parse_foci_section},
    {"pulse", false, parse_pulse_section},
    {"calibration", false, parse_calibration_section},
    {"effects", false, parse_effects_section},
    {"tolerance", false, parse_tolerance_section},
};

} // namespace

Scene parse_scene(std::string_view text, const std::string &file_name)
{
    Scene scene;
    scene.file = file_name;
    toml::table root;
    try {
        root = toml::parse(text, file_name);
    } catch (const toml::parse_error &e) {
        std::ostringstream msg;
        msg << file_name << ":" << e.source().begin.line << ":" << e.source().begin.column
            << ": TOML syntax error: " << e.description();
        throw SceneError(msg.str());
    }
    for (const auto &[key, node] : root) {
        if (key.str() == "name") {
            if (!node.is_string())
                throw SceneError(file_name + ": name: must be a string");
            scene.name = *node.value<std::string>();
            continue;
        }
        bool known = false;
        for (const Section &s : sections)
            known = known || key.str() == s.name;
        if (!known) {
            std::string list;
            for (const Section &s : sections)
                list += (list.empty() ? "" : ", ") + std::string(s.name);
            throw SceneError(file_name + ": " + std::string(key.str()) + ": unknown section (known: name, " + list +
                             ")");
        }
    }
    for (const Section &s : sections) {
        const toml::node *n = root.get(s.name);
        if (!n) {
            if (s.required)
                throw SceneError(file_name + ": " + s.name + ": missing section");
            continue;
        }
        if (!n->as_table())
            throw SceneError(file_name + ": " + s.name + ": must be a table ([" + s.name + "])");
        s.parse(*n->as_table(), scene);
    }
    if (scene.name.empty())
        scene.name = std::filesystem::path(file_name).stem().string();
    // The grid resolves the pulse's band unless told otherwise.
    if (scene.simulation.f_max_hz == 0 && !scene.simulation.grid_spacing_m) {
        if (!scene.pulse)
            throw SceneError(file_name + ": simulation.f_max_hz: missing (required unless grid_spacing_m is given or "
                                         "the scene has a [pulse])");
        scene.simulation.f_max_hz = pipeline::pulse_max_frequency_hz(*scene.pulse);
    }
    return scene;
}

Scene load_scene(const std::string &path)
{
    const std::optional<std::string> bytes = io::read_file(path);
    if (!bytes)
        throw SceneError(path + ": cannot open scene file");
    return parse_scene(*bytes, path);
}

engine::Grid plate_grid(const Scene &scene)
{
    const PlateSpec &p = scene.plate;
    const SimulationSpec &s = scene.simulation;
    double h_max;
    if (s.grid_spacing_m) {
        h_max = *s.grid_spacing_m;
    } else {
        // The Kirchhoff A0 wavelength at f_max.
        const double wavelength = physics::kirchhoff_wavelength_m(p.material.kappa(p.thickness_m), s.f_max_hz);
        h_max = wavelength / s.points_per_wavelength;
    }
    // Counted in floating point before any grid exists: an absurd size or
    // spacing is refused here, at once, not after an allocation.
    const double cells_x = std::ceil(p.size_x_m / h_max), cells_y = std::ceil(p.size_y_m / h_max);
    if (!(cells_x * cells_y <= 2e8)) {
        char b[200];
        std::snprintf(b, sizeof b, "a grid of %.3g x %.3g = %.3g cells of %.3g m (the engine takes at most 2e8)",
                      cells_x, cells_y, cells_x * cells_y, h_max);
        throw SceneError(scene.file + ": plate.size_m with simulation." +
                         (s.grid_spacing_m ? "grid_spacing_m" : "points_per_wavelength and f_max_hz") + ": " + b);
    }
    return engine::make_grid(p.size_x_m, p.size_y_m, h_max);
}

PlateSetup build_plate(const Scene &scene)
{
    const PlateSpec &p = scene.plate;
    const SimulationSpec &s = scene.simulation;
    engine::PlateParams params;
    params.size_x_m = p.size_x_m;
    params.size_y_m = p.size_y_m;
    params.thickness_m = p.thickness_m;
    params.material = p.material;
    params.edges = p.edges;
    const double kappa = p.material.kappa(p.thickness_m);
    if (p.loss && scene.effects.loss.value_or(true)) { // effects.loss = false switches it off
        try {
            params.loss = engine::loss_from_t60(kappa, p.loss->f1_hz, p.loss->t60_1_s, p.loss->f2_hz, p.loss->t60_2_s);
        } catch (const std::invalid_argument &e) {
            throw SceneError(scene.file + ": plate.loss: " + e.what());
        }
    }
    const engine::Grid grid = plate_grid(scene);
    PlateSetup setup;
    setup.plate = std::make_shared<const engine::PlateOperator>(params, grid);
    setup.options.precision = s.precision;
    setup.options.courant = s.courant;
    setup.options.engine.threads = s.threads;
    if (s.time_step_s) {
        try {
            engine::check_stable_time_step(*setup.plate, *s.time_step_s);
        } catch (const std::invalid_argument &e) {
            throw SceneError(scene.file + ": simulation.time_step_s: " + e.what());
        }
        setup.options.time_step_s = *s.time_step_s;
    }
    // The thick plate runs on its own operator: built here, once, for every
    // simulation of the scene.
    if (scene.effects.thick_plate) {
        try {
            setup.options.thick_plate_operator = std::make_shared<const engine::mindlin::MindlinOperator>(params, grid);
        } catch (const std::invalid_argument &e) {
            throw SceneError(scene.file + ": effects.thick_plate: " + e.what());
        }
        setup.options.thick_plate = true;
    }
    return setup;
}

} // namespace calib::scene
