#include "io/heap.h"

#include <malloc.h>

namespace calib::io {

void keep_freed_heap()
{
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    // Setting the trim threshold freezes glibc's mmap threshold at 128 KB (it
    // otherwise rises to the largest block freed): every field and recording
    // buffer would then be mapped, faulted in and unmapped per run (a
    // 1024 x 1024 simulation: 1.25-1.64 against 2.34-2.83 Gcell/s). 32 MB is
    // glibc's largest.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
}

} // namespace calib::io
