// Axis ranges and tick marks: linear axes get 1-2-2.5-5 steps, log axes decade
// ticks with 2..9 minor ticks while at most 8 decades are shown.
#pragma once
#include "report/plot.h"

#include <string>
#include <vector>

namespace calib::report {

struct Ticks {
    double lo = 0, hi = 0; // axis range (data units)
    std::vector<double> major, minor;
    std::vector<std::string> labels; // one per major tick
};

// The range is the axis's min/max where set, else [data_min, data_max]
// widened to whole ticks. `which` names the axis in errors ("x", "y").
// Throws std::invalid_argument for a log axis with min or max <= 0.
Ticks make_ticks(const Axis &axis, double data_min, double data_max, const char *which);

} // namespace calib::report
