#include "report/contour.h"

#include <cmath>

namespace calib::report {

std::vector<ContourSegment> contour_segments(const FieldMap &f, double level)
{
    std::vector<ContourSegment> out;
    if (f.nx < 2 || f.ny < 2 || f.value.size() != static_cast<std::size_t>(f.nx) * static_cast<std::size_t>(f.ny))
        return out;
    auto v = [&](int i, int j) { return static_cast<double>(f.value[static_cast<std::size_t>(j) * f.nx + i]); };
    struct P {
        double x, y;
    };
    for (int j = 0; j + 1 < f.ny; ++j)
        for (int i = 0; i + 1 < f.nx; ++i) {
            // Corners counter-clockwise from bottom-left; edge k joins corner k and k + 1.
            const double c[4] = {v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)};
            if (!std::isfinite(c[0]) || !std::isfinite(c[1]) || !std::isfinite(c[2]) || !std::isfinite(c[3]))
                continue;
            const bool in[4] = {c[0] >= level, c[1] >= level, c[2] >= level, c[3] >= level};
            if (in[0] == in[1] && in[1] == in[2] && in[2] == in[3])
                continue;
            const double cx[4] = {0, 1, 1, 0}, cy[4] = {0, 0, 1, 1};
            auto crossing = [&](int k) {
                const int a = k, b = (k + 1) % 4;
                const double t = (level - c[a]) / (c[b] - c[a]);
                return P{f.x0_m + (i + cx[a] + t * (cx[b] - cx[a])) * f.dx_m,
                         f.y0_m + (j + cy[a] + t * (cy[b] - cy[a])) * f.dy_m};
            };
            auto add = [&](int e0, int e1) {
                const P p = crossing(e0), q = crossing(e1);
                out.push_back({p.x, p.y, q.x, q.y});
            };
            const bool saddle = in[0] == in[2] && in[1] == in[3];
            if (!saddle) {
                int e[2], n = 0;
                for (int k = 0; k < 4; ++k)
                    if (in[k] != in[(k + 1) % 4])
                        e[n++] = k;
                add(e[0], e[1]);
                continue;
            }
            // Corner k touches edges k - 1 and k; cut off the corners on the
            // other side of the level than the cell centre.
            const bool centre_in = 0.25 * (c[0] + c[1] + c[2] + c[3]) >= level;
            for (int k = 0; k < 4; ++k)
                if (in[k] != centre_in)
                    add((k + 3) % 4, k);
        }
    return out;
}

} // namespace calib::report
