#include "io/heap.h"

#include <malloc.h>

namespace calib::io {

void keep_freed_heap()
{
    mallopt(M_TRIM_THRESHOLD, 256 << 20);
    // Setting the trim threshold freezes glibc's mmap threshold at 128 KB (it
    // otherwise rises to the largest block freed): every field and recording
    // buffer would then be mapped, faulted in and unmapped per run (a
    // 1024 x 1024 simulation ran at half its rate). 32 MB is glibc's largest.
    mallopt(M_MMAP_THRESHOLD, 32 << 20);
}

} // namespace calib::io
