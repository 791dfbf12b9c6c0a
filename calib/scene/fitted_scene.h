// A scene with what a bench fit measured (docs/bench.md): the scene file's
// own values replaced, so that calibrating it designs for the panel that was
// measured. The modulus E scaled by alpha^2 (the speed ratio alpha is kappa's,
// kappa ~ sqrt(E) at the scene's density and thickness), the loss law scaled
// to the fitted loss factor (each T60 divided by eta / eta_scene), the
// exciters fixed at their fitted positions with their force gains. A comment
// block at the top says what was fitted from what.
#pragma once
#include "pipeline/data/geometry.h"
#include "scene/scene.h"

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace calib::scene {

struct FittedValues {
    double speed_ratio = 1;
    double loss_scale = 1; // fitted loss factor / the scene's
    std::vector<pipeline::Point> exciters;
    std::vector<double> force_gains;
    std::optional<engine::EdgeKind> edges; // every edge, when the fit chose the condition
    std::string comment;                   // lines, each written after "# "
};

// Throws SceneError when the text does not parse (it was read once already).
std::string fitted_scene_text(std::string_view scene_text, const Scene &scene, const FittedValues &fit);

} // namespace calib::scene
