#include "pipeline/data/geometry.h"

namespace calib::pipeline {

bool Band::allows(Point p) const
{
    return p.x_m >= frame_margin_m && p.x_m <= plate_x_m - frame_margin_m && p.y_m >= frame_margin_m &&
           p.y_m <= plate_y_m - frame_margin_m && !active_area.contains(p, clearance_m);
}

} // namespace calib::pipeline
