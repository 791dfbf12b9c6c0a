// The plate's lowest modes in the calibration report (`calibrate --modes N`):
// a table of frequencies, decay times and symmetries, the first shapes as
// images, and the same figures in metrics.json.
#pragma once
#include "engine/modes.h"
#include "engine/plate_operator.h"

#include <toml++/toml.h>

#include <string>

namespace calib::report {

// HTML section: every mode in the table, the first `images` shapes drawn.
std::string modes_html(const engine::PlateModes &modes, const engine::PlateOperator &op, int images = 6);
// [{mode, frequency_hz, decay_rate_1_s, t60_s (absent without loss), x_symmetry, y_symmetry}, ...]
toml::array modes_json(const engine::PlateModes &modes);

} // namespace calib::report
