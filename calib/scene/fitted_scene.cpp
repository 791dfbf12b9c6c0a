#include "scene/fitted_scene.h"

#include "scene/toml_fields.h"

#include <toml++/toml.h>

#include <sstream>

namespace calib::scene {

std::string fitted_scene_text(std::string_view scene_text, const Scene &scene, const FittedValues &fit)
{
    toml::table root;
    try {
        root = toml::parse(scene_text, scene.file);
    } catch (const toml::parse_error &e) {
        throw SceneError(scene.file + ": " + std::string(e.description()));
    }
    toml::table &plate = *root["plate"].as_table();
    const physics::Material &m = scene.plate.material;
    plate.insert_or_assign("material", toml::table{{"name", m.name + " (fitted)"},
                                                   {"density_kg_m3", m.density_kg_m3},
                                                   {"youngs_pa", m.youngs_pa * fit.speed_ratio * fit.speed_ratio},
                                                   {"poisson", m.poisson}});
    if (fit.edges)
        plate.insert_or_assign("edges", engine::edge_kind_name(*fit.edges));
    if (toml::table *loss = plate["loss"].as_table(); loss && fit.loss_scale != 1) {
        if (const toml::array *t60 = (*loss)["t60_s"].as_array()) {
            toml::array scaled;
            for (const toml::node &v : *t60)
                scaled.push_back(v.value<double>().value_or(0.0) / fit.loss_scale);
            loss->insert_or_assign("t60_s", std::move(scaled));
        }
    }
    toml::table &ex = *root["exciters"].as_table();
    for (const char *key : {"placement", "positions_m", "force_gains", "criterion", "seed", "restarts", "iterations",
                            "verdict_rounds", "site_spacing_m", "contrast_window", "placement_foci", "min_spacing_m"})
        ex.erase(key);
    ex.insert_or_assign("placement", "fixed");
    toml::array pos, gains;
    for (const pipeline::Point &p : fit.exciters)
        pos.push_back(toml::array{p.x_m, p.y_m});
    for (double g : fit.force_gains)
        gains.push_back(g);
    ex.insert_or_assign("positions_m", std::move(pos));
    ex.insert_or_assign("force_gains", std::move(gains));
    std::ostringstream out;
    for (std::size_t at = 0; at < fit.comment.size();) {
        const std::size_t nl = fit.comment.find('\n', at);
        const std::size_t end = nl == std::string::npos ? fit.comment.size() : nl;
        out << "# " << fit.comment.substr(at, end - at) << "\n";
        at = end + 1;
    }
    out << "\n" << root << "\n";
    return out.str();
}

} // namespace calib::scene
