// [effects]: which physical effects the simulation composes (docs/scene-format.md).
#pragma once

#include "engine/effects/effects.h"
#include "scene/toml_fields.h"

namespace calib::scene {

struct PlateSpec;

// `plate` is the already parsed [plate] (positions are checked against it,
// `loss = true` needs its [plate.loss]). Throws SceneError naming the key.
engine::effects::EffectsSpec parse_effects(const Fields &f, const PlateSpec &plate);

} // namespace calib::scene
