#include "io/heap.h"

#include <malloc.h>

namespace calib::io {

void keep_freed_heap() { mallopt(M_TRIM_THRESHOLD, 256 << 20); }

} // namespace calib::io
