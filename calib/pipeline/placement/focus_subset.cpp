#include "pipeline/placement/focus_subset.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace calib::pipeline {

namespace {} // namespace

double covering_radius(const std::vector<Point> &foci, const std::vector<std::size_t> &members)
{
    double r = 0;
    for (const Point &p : foci) {
        double near = std::numeric_limits<double>::infinity();
        for (std::size_t m : members)
            near = std::min(near, dist(p, foci.at(m)));
        r = std::max(r, near);
    }
    return r;
}

FocusSubset farthest_point_subset(const std::vector<Point> &foci, std::size_t cap, double min_separation_m)
{
    if (cap == 0)
        throw std::invalid_argument("focus subset: the cap must be >= 1");
    FocusSubset s;
    if (foci.size() <= cap) {
        for (std::size_t i = 0; i < foci.size(); i++)
            s.members.push_back(i);
        return s; // every focus is a member: covering radius 0
    }
    // Start: the focus nearest the middle of the bounding box (lowest index on a tie).
    double x0 = foci[0].x_m, x1 = x0, y0 = foci[0].y_m, y1 = y0;
    for (const Point &p : foci) {
        x0 = std::min(x0, p.x_m);
        x1 = std::max(x1, p.x_m);
        y0 = std::min(y0, p.y_m);
        y1 = std::max(y1, p.y_m);
    }
    const Point mid{(x0 + x1) / 2, (y0 + y1) / 2};
    std::size_t first = 0;
    for (std::size_t i = 1; i < foci.size(); i++)
        if (dist(foci[i], mid) < dist(foci[first], mid))
            first = i;
    // near[i]: distance from focus i to the nearest member, updated per member
    // added: O(foci x cap) in all.
    std::vector<double> near(foci.size(), std::numeric_limits<double>::infinity());
    std::size_t next = first;
    while (true) {
        s.members.push_back(next);
        for (std::size_t i = 0; i < foci.size(); i++)
            near[i] = std::min(near[i], dist(foci[i], foci[next]));
        std::size_t far = 0;
        for (std::size_t i = 1; i < foci.size(); i++)
            if (near[i] > near[far])
                far = i;
        s.covering_radius_m = near[far];
        // Each new member lies near[far] from the others, and near[far] only
        // shrinks: stopping at min_separation keeps the members that far apart.
        if (s.members.size() == cap || near[far] <= min_separation_m || near[far] == 0)
            break;
        next = far;
    }
    return s;
}

std::size_t placement_focus_cap(std::optional<unsigned> asked, double sites, double lags)
{
    if (asked)
        return std::max(1u, *asked);
    const double per_focus_squared = std::max(1.0, sites) * std::max(1.0, lags) * sizeof(float);
    const double fits = std::floor(std::sqrt(max_contrast_model_bytes / per_focus_squared));
    return static_cast<std::size_t>(
        std::clamp(fits, double(min_default_placement_foci), double(default_placement_foci)));
}

double contrast_model_lags(double window_s, double truncate_fraction, double search_rate_hz)
{
    const double n = std::round(window_s * search_rate_hz);
    return std::max(1.0, std::round(truncate_fraction * n) + n - 1);
}

} // namespace calib::pipeline
