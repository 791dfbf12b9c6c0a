// A plate mode shape as an image: a diverging map (blue -1, white 0, red +1)
// so the nodal lines are the white ones, y up. `calibgen modes --png` writes
// it as a file, the calibration report embeds it.
#pragma once
#include "report/image.h"

#include <vector>

namespace calib::report {

// field: node values row-major (j, i), scaled to max |w| = 1 (engine::mode_field);
// each node a square of pixels so the image is about `target_px` across.
Image mode_shape_image(const std::vector<double> &field, int nodes_x, int nodes_y, int target_px = 400);

} // namespace calib::report
