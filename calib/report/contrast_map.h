// A per-focus figure (e.g. whole-area contrast) as a map over the active
// area, for render_field: each sample of a lattice over the area takes the
// value of its nearest focus, so every focus is drawn as its own cell (its
// Voronoi cell) whatever the foci's layout, grid or scattered. The lattice
// covers the area only: the plate around it is drawn as "no data".
#pragma once
#include "pipeline/placement/placement.h"
#include "report/field_image.h"

#include <vector>

namespace calib::report {

// `samples` lattice points along the longer side of `area` (>= 2), the
// other side in proportion. A NaN value leaves its cell NaN. Throws
// std::invalid_argument for no foci, sizes that differ, an empty area or
// fewer than 2 samples.
FieldMap nearest_focus_map(const std::vector<pipeline::Point> &foci, const std::vector<double> &values,
                           const pipeline::Rect &area, int samples = 240);

} // namespace calib::report
