// The tolerance box in calibrate's outputs: the worst case over the scene's
// [tolerance] next to the nominal figures (metrics.json, the terminal
// summary, the HTML report); with a robust design, the plain design's beside
// it and what the robust one cost (docs/robustness.md).
#pragma once
#include "pipeline/data/tolerance_spec.h"

#include <toml++/toml.h>

#include <cstddef>
#include <string>

namespace calib::report {

toml::table tolerance_json(const pipeline::ToleranceReport &r);
// Lines for stderr after the per-focus summary.
std::string tolerance_text(const pipeline::ToleranceReport &r, std::size_t foci);
// An <h2> section with the table of every plate.
std::string tolerance_html(const pipeline::ToleranceReport &r, std::size_t foci);

} // namespace calib::report
