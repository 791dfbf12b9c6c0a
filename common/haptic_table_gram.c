/* haptic_table_gram.c - the exact inner product behind the Gram matrix, for
 * the writer (which computes it), the reader (which checks it against the
 * payload) and the Gram matrix of derived drives (haptic_table_gram_of).
 * Its own unit so the build can give this one loop the vectoriser
 * (common/CMakeLists.txt); the arithmetic is integer, so the result does not
 * depend on how the compiler orders the sum. */
#include "haptic_table_internal.h"

/* Each product p = a b (|p| <= 2^30) is split as p = 65536 hi + lo with lo its
 * low 16 bits (0..65535) and hi = p >> 16 (-16384..16384): over a block of at
 * most 65536 products the lo sum stays below 2^32 in a uint32 and the hi sum
 * within +-2^30 in an int32, so both are exact, and 32-bit lanes vectorise
 * about twice as fast as widening every product to 64 bits (docs/BENCHMARKS.md).
 * GCC and Clang shift signed values arithmetically. */
int64_t haptic_table_dot_(const int16_t *a, const int16_t *b, uint64_t n)
{
    int64_t total = 0;
    for (uint64_t start = 0; start < n; start += 65536) {
        const uint64_t m = n - start < 65536 ? n - start : 65536;
        const int16_t *x = a + start, *y = b + start;
        uint32_t lo = 0;
        int32_t hi = 0;
        for (uint64_t i = 0; i < m; i++) {
            const int32_t p = (int32_t)x[i] * (int32_t)y[i];
            lo += (uint16_t)p;
            hi += (int16_t)(p >> 16);
        }
        total += (int64_t)hi * 65536 + lo;
    }
    return total;
}

void haptic_table_gram_of(const int16_t *signals, uint32_t K, uint64_t n, double *gram)
{
    for (uint32_t i = 0; i < K; i++)
        for (uint32_t j = 0; j <= i; j++)
            gram[(size_t)i * K + j] = gram[(size_t)j * K + i] =
                (double)haptic_table_dot_(signals + (size_t)i * n, signals + (size_t)j * n, n);
}
