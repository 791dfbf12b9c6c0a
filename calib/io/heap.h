// The process's heap policy: calibgen's main and the benchmarks that time
// what calibgen runs.
#pragma once

namespace calib::io {

// The pipeline frees and allocates buffers of the same sizes over and over
// (each simulation's recordings and field copies, their resampled copies);
// glibc gives the top of its heap back to the kernel once 128 KB of it are
// free, and every page is faulted in again when the next buffer takes it. On
// a paravirtualised machine that was a quarter of a Fig. 7 calibration, and
// recording 464 sites cost 1.5-1.7x recording one (docs/BENCHMARKS.md,
// "Overlapping trapezoids"). Keeps up to 256 MB free in the heap instead, and
// blocks up to 32 MB in the heap rather than mapped one by one. The peak
// rose by a tenth at most (Fig. 7: 305-316 MB against 271-302; dense Fig. 7:
// 965 MB both).
void keep_freed_heap();

} // namespace calib::io
