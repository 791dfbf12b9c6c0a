#include "report/contrast_map.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace calib::report {

FieldMap nearest_focus_map(const std::vector<pipeline::Point> &foci, const std::vector<double> &values,
                           const pipeline::Rect &area, int samples)
{
    if (foci.empty() || foci.size() != values.size())
        throw std::invalid_argument("focus map: " + std::to_string(foci.size()) + " foci and " +
                                    std::to_string(values.size()) + " values");
    const double w = area.x1_m - area.x0_m, h = area.y1_m - area.y0_m;
    if (!(w > 0) || !(h > 0) || samples < 2)
        throw std::invalid_argument("focus map: an empty area or fewer than 2 samples");
    const double step = std::max(w, h) / (samples - 1);
    FieldMap m;
    m.nx = std::max(2, static_cast<int>(std::lround(w / step)) + 1);
    m.ny = std::max(2, static_cast<int>(std::lround(h / step)) + 1);
    m.x0_m = area.x0_m;
    m.y0_m = area.y0_m;
    m.dx_m = w / (m.nx - 1);
    m.dy_m = h / (m.ny - 1);
    m.value.resize(static_cast<std::size_t>(m.nx) * static_cast<std::size_t>(m.ny));
    for (int j = 0; j < m.ny; j++)
        for (int i = 0; i < m.nx; i++) {
            const double x = m.x0_m + i * m.dx_m, y = m.y0_m + j * m.dy_m;
            std::size_t best = 0;
            double bd = std::numeric_limits<double>::infinity();
            for (std::size_t f = 0; f < foci.size(); f++) {
                const double d = std::hypot(foci[f].x_m - x, foci[f].y_m - y);
                if (d < bd) {
                    bd = d;
                    best = f;
                }
            }
            m.value[static_cast<std::size_t>(j) * m.nx + i] = static_cast<float>(values[best]);
        }
    return m;
}

} // namespace calib::report
