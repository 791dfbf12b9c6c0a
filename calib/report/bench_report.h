// The bench fit's report (docs/bench.md): DIR/index.html (the fitted values
// with their uncertainties and what the sensors cannot tell apart, the
// residual per sensor and exciter before and after, and for each pair the
// measured response over the simulated one with the scene's values and the
// fitted ones, inline SVG) and DIR/fit.json with the same figures.
#pragma once
#include "pipeline/bench/bench_fit.h"

#include <string>

namespace calib::report {

void write_bench_report(const std::string &dir, const pipeline::BenchModel &model,
                        const pipeline::BenchMeasured &measured, const pipeline::BenchFitResult &r);

} // namespace calib::report
