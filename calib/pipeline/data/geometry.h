// Points and rectangles on the plate (metres, origin at its lower-left
// corner), the distance between two points, and the band where exciters may
// go: the geometry every stage shares.
#pragma once
#include <cmath>

namespace calib::pipeline {

struct Point {
    double x_m = 0, y_m = 0;
};
inline double dist(Point a, Point b) { return std::hypot(a.x_m - b.x_m, a.y_m - b.y_m); }

struct Rect {
    double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;
    bool contains(Point p, double grow_m = 0) const
    {
        return p.x_m >= x0_m - grow_m && p.x_m <= x1_m + grow_m && p.y_m >= y0_m - grow_m && p.y_m <= y1_m + grow_m;
    }
};

// Where exciters may go: on the plate, at least frame_margin from its edge,
// and outside the active (transparent) area grown by clearance.
struct Band {
    double plate_x_m = 0, plate_y_m = 0;
    double frame_margin_m = 0;
    Rect active_area;
    double clearance_m = 0;
    bool allows(Point p) const;
};

} // namespace calib::pipeline
