#include "io/heap.h"

#include <malloc.h>

namespace calib::io {

void keep_freed_heap()
{
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    // Setting the trim threshold freezes glibc's mmap threshold at 128 KB (it
    // otherwise rises with the largest block freed, up to 32 MB on 64-bit
    // systems): every field and recording buffer would then be mapped,
    // faulted in and unmapped per run (a 1024 x 1024 simulation: 1.25-1.64
    // against 2.34-2.83 Gcell/s). It is set where the sliding threshold
    // would stop.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
}

} // namespace calib::io
