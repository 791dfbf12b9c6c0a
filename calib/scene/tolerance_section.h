// The [tolerance] section and the [calibration] key `robust` (docs/scene-format.md,
// docs/robustness.md): what a panel may differ by, and the plates a robust
// design is computed over. Every error names the key.
#pragma once
#include "pipeline/data/tolerance_spec.h"
#include "scene/toml_fields.h"

namespace calib::scene {

struct PlateSpec;

// `plate` (already parsed) names the thickness and material in refusals.
pipeline::ToleranceSpec parse_tolerance(const Fields &f, const PlateSpec &plate);
// `robust = { loss = [...], E_scale = [...] }` of [calibration]; `f` is [calibration].
pipeline::RobustSpec parse_robust(const Fields &f);

} // namespace calib::scene
