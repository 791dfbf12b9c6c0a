// Parsers of the calibration sections of a scene: [active_area], [exciters],
// [foci], [pulse], [calibration] (docs/scene-format.md). Each fills the
// pipeline's plain spec and names the key in every error.
#pragma once
#include "pipeline/data/spec.h"
#include "pipeline/signal/pulse.h"
#include "scene/toml_fields.h"

namespace calib::scene {

pipeline::ActiveAreaSpec parse_active_area(const Fields &f);
pipeline::ExcitersSpec parse_exciters(const Fields &f);
// The grid form needs the active area it divides.
pipeline::FociSpec parse_foci(const Fields &f, const pipeline::ActiveAreaSpec &active);
pipeline::PulseSpec parse_pulse(const Fields &f);
pipeline::CalibrationSpec parse_calibration(const Fields &f);

} // namespace calib::scene
