// Perceptually uniform colour map for field images.
#pragma once
#include "report/image.h"

namespace calib::report {

// viridis: lightness rises monotonically and evenly from dark blue (low) to
// yellow (high), so equal steps of the field look equally large, the order is
// readable in grey print, and the map suits the common colour-vision
// deficiencies. t in [0, 1] (clamped; NaN gives entry 0); entry i of the
// 256-entry table covers [i/256, (i+1)/256), as matplotlib looks it up.
Color viridis(double t);
Color viridis_entry(int i); // i in 0..255 (clamped)

} // namespace calib::report
