// Iso-lines of a sampled field by marching squares (Lorensen and Cline's
// marching cubes in two dimensions): in every cell of four samples, the
// crossings of the level on the cell edges, linearly interpolated, joined in
// pairs. The segments are the level set of the bilinear interpolant on the
// cell edges, which is what render_field paints, so the contour sits where
// the colours cross the level.
#pragma once
#include "report/field_image.h"

#include <vector>

namespace calib::report {

struct ContourSegment {
    double x0_m, y0_m, x1_m, y1_m;
};

// Cells with a NaN corner have no contour. A saddle cell (opposite corners on
// the same side of the level) is split by the mean of its four samples.
std::vector<ContourSegment> contour_segments(const FieldMap &field, double level);

} // namespace calib::report
