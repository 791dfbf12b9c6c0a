#include "engine/plate_kernels.h"

#include <omp.h>

#include <cstddef>

namespace calib::engine {

namespace {

// Several output rows per pass: rows j-2 .. j+3 are loaded once for two
// outputs, and the horizontal pair sums of rows j and j+1 are shared between
// their s1 and s2 (18 loads of u per 2 nodes instead of 26). No branches
// inside the i loop.
template <typename T, bool Lossy>
inline __attribute__((always_inline)) void bulk_body(const T *__restrict u, const T *__restrict up,
                                                     T *__restrict un, std::ptrdiff_t s, int i0, int i1, int j0,
                                                     int j1, const BulkCoefficients<T> &c)
{
    const T g = c.g, mu2 = c.mu2, nu1 = c.nu1;
    int j = j0;
    // Four output rows per pass: the centre of rows j-2 .. j+5, the horizontal
    // pair sums of rows j-1 .. j+4 and the distance-2 pairs of rows j .. j+3
    // are each loaded or formed once (8 loads per node instead of 10). Only
    // while the 16 rows it streams fit in L1: on long rows it was measured
    // 10-15 % slower than the two-row pass below.
    const bool four_rows = std::size_t(i1 - i0) * sizeof(T) * 16 <= 32768;
    if constexpr (!Lossy) {
        for (; four_rows && j + 3 < j1; j += 4) {
            const T *__restrict r[8];
            for (int k = 0; k < 8; ++k)
                r[k] = u + (j - 2 + k) * s;
            const T *__restrict p0 = up + j * s;
            T *__restrict o0 = un + j * s;
#pragma omp simd
            for (int i = i0; i < i1; ++i) {
                T cc[8], hh[6], qq[4];
#pragma GCC unroll 8
                for (int k = 0; k < 8; ++k)
                    cc[k] = r[k][i];
#pragma GCC unroll 6
                for (int k = 0; k < 6; ++k)
                    hh[k] = r[k + 1][i - 1] + r[k + 1][i + 1];
#pragma GCC unroll 4
                for (int k = 0; k < 4; ++k)
                    qq[k] = r[k + 2][i - 2] + r[k + 2][i + 2];
#pragma GCC unroll 4
                for (int k = 0; k < 4; ++k) {
                    const T s1 = hh[k + 1] + (cc[k + 1] + cc[k + 3]);
                    const T s2 = hh[k] + hh[k + 2];
                    const T s3 = qq[k] + (cc[k] + cc[k + 4]);
                    const T lap2 = T(20) * cc[k + 2] - T(8) * s1 + T(2) * s2 + s3;
                    const T ctr = cc[k + 2];
                    o0[k * s + i] = ctr + g * (ctr - p0[k * s + i]) - mu2 * lap2;
                }
            }
        }
    }
    for (; j + 1 < j1; j += 2) {
        const T *__restrict rm2 = u + (j - 2) * s;
        const T *__restrict rm1 = u + (j - 1) * s;
        const T *__restrict r0 = u + j * s;
        const T *__restrict r1 = u + (j + 1) * s;
        const T *__restrict r2 = u + (j + 2) * s;
        const T *__restrict r3 = u + (j + 3) * s;
        const T *__restrict p0 = up + j * s;
        const T *__restrict p1 = up + (j + 1) * s;
        T *__restrict o0 = un + j * s;
        T *__restrict o1 = un + (j + 1) * s;
#pragma omp simd
        for (int i = i0; i < i1; ++i) {
            const T c0 = r0[i], c1 = r1[i];
            const T h0 = r0[i - 1] + r0[i + 1];
            const T h1 = r1[i - 1] + r1[i + 1];
            const T s1a = h0 + rm1[i] + c1;
            const T s1b = h1 + c0 + r2[i];
            const T s2a = (rm1[i - 1] + rm1[i + 1]) + h1;
            const T s2b = h0 + (r2[i - 1] + r2[i + 1]);
            const T s3a = (r0[i - 2] + r0[i + 2]) + (rm2[i] + r2[i]);
            const T s3b = (r1[i - 2] + r1[i + 2]) + (rm1[i] + r3[i]);
            const T lap2a = T(20) * c0 - T(8) * s1a + T(2) * s2a + s3a;
            const T lap2b = T(20) * c1 - T(8) * s1b + T(2) * s2b + s3b;
            T va = c0 + g * (c0 - p0[i]) - mu2 * lap2a;
            T vb = c1 + g * (c1 - p1[i]) - mu2 * lap2b;
            if constexpr (Lossy) {
                const T *__restrict pm1 = up + (j - 1) * s;
                const T *__restrict p2 = up + (j + 2) * s;
                const T lapc_a = T(4) * c0 - s1a, lapc_b = T(4) * c1 - s1b;
                const T lapp_a = T(4) * p0[i] - ((p0[i - 1] + p0[i + 1]) + (pm1[i] + p1[i]));
                const T lapp_b = T(4) * p1[i] - ((p1[i - 1] + p1[i + 1]) + (p0[i] + p2[i]));
                va += nu1 * (lapp_a - lapc_a);
                vb += nu1 * (lapp_b - lapc_b);
            }
            o0[i] = va;
            o1[i] = vb;
        }
    }
    for (; j < j1; ++j) {
        const T *__restrict rm2 = u + (j - 2) * s;
        const T *__restrict rm1 = u + (j - 1) * s;
        const T *__restrict r0 = u + j * s;
        const T *__restrict r1 = u + (j + 1) * s;
        const T *__restrict r2 = u + (j + 2) * s;
        const T *__restrict p0 = up + j * s;
        T *__restrict o0 = un + j * s;
#pragma omp simd
        for (int i = i0; i < i1; ++i) {
            const T s1 = (r0[i - 1] + r0[i + 1]) + rm1[i] + r1[i];
            const T s2 = (rm1[i - 1] + rm1[i + 1]) + (r1[i - 1] + r1[i + 1]);
            const T s3 = (r0[i - 2] + r0[i + 2]) + (rm2[i] + r2[i]);
            const T lap2 = T(20) * r0[i] - T(8) * s1 + T(2) * s2 + s3;
            T v = r0[i] + g * (r0[i] - p0[i]) - mu2 * lap2;
            if constexpr (Lossy) {
                const T *__restrict pm1 = up + (j - 1) * s;
                const T *__restrict pp1 = up + (j + 1) * s;
                const T lapc = T(4) * r0[i] - s1;
                const T lapp = T(4) * p0[i] - ((p0[i - 1] + p0[i + 1]) + (pm1[i] + pp1[i]));
                v += nu1 * (lapp - lapc);
            }
            o0[i] = v;
        }
    }
}

}  // namespace

// Run-time ISA dispatch: the same body compiled for AVX-512 (with 512-bit
// vectors: GCC otherwise prefers 256-bit ones on x86-64-v4), AVX2+FMA and the
// baseline, chosen once from the CPU. Sanitizer builds keep the baseline only.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(HAPTIC_NO_TARGET_CLONES)
#define HAPTIC_DISPATCH 1
#endif

template <typename T>
using BulkFn = void (*)(const T *, const T *, T *, std::ptrdiff_t, int, int, int, int, const BulkCoefficients<T> &);

#define HAPTIC_BULK_VARIANT(NAME, ATTR)                                                                       \
    template <typename T, bool Lossy>                                                                         \
    ATTR void NAME(const T *u, const T *up, T *un, std::ptrdiff_t s, int i0, int i1, int j0, int j1,         \
                   const BulkCoefficients<T> &c)                                                              \
    {                                                                                                         \
        bulk_body<T, Lossy>(u, up, un, s, i0, i1, j0, j1, c);                                                 \
    }

HAPTIC_BULK_VARIANT(bulk_baseline, )
#ifdef HAPTIC_DISPATCH
HAPTIC_BULK_VARIANT(bulk_avx512, __attribute__((target("arch=x86-64-v4,prefer-vector-width=512"))))
HAPTIC_BULK_VARIANT(bulk_avx2, __attribute__((target("arch=x86-64-v3"))))
#endif

namespace {

int isa_level()
{
#ifdef HAPTIC_DISPATCH
    __builtin_cpu_init();
    if (__builtin_cpu_supports("x86-64-v4"))
        return 2;
    if (__builtin_cpu_supports("x86-64-v3"))
        return 1;
#endif
    return 0;
}

template <typename T, bool Lossy>
BulkFn<T> select_bulk()
{
#ifdef HAPTIC_DISPATCH
    switch (isa_level()) {
    case 2: return bulk_avx512<T, Lossy>;
    case 1: return bulk_avx2<T, Lossy>;
    default: break;
    }
#endif
    return bulk_baseline<T, Lossy>;
}

}  // namespace

template <typename T, bool Lossy>
void bulk_update(const T *u, const T *up, T *un, std::ptrdiff_t s, int i0, int i1, int j0, int j1,
                 const BulkCoefficients<T> &c)
{
    static const BulkFn<T> fn = select_bulk<T, Lossy>();
    fn(u, up, un, s, i0, i1, j0, j1, c);
}

template void bulk_update<float, false>(const float *, const float *, float *, std::ptrdiff_t, int, int, int, int,
                                        const BulkCoefficients<float> &);
template void bulk_update<float, true>(const float *, const float *, float *, std::ptrdiff_t, int, int, int, int,
                                       const BulkCoefficients<float> &);
template void bulk_update<double, false>(const double *, const double *, double *, std::ptrdiff_t, int, int, int, int,
                                         const BulkCoefficients<double> &);
template void bulk_update<double, true>(const double *, const double *, double *, std::ptrdiff_t, int, int, int, int,
                                        const BulkCoefficients<double> &);

template <typename T, bool Lossy>
void bulk_update_threads(const T *u, const T *up, T *un, std::ptrdiff_t s, int i0, int i1, int j0, int j1,
                         const BulkCoefficients<T> &c, int threads)
{
    if (threads <= 1) {
        bulk_update<T, Lossy>(u, up, un, s, i0, i1, j0, j1, c);
        return;
    }
#pragma omp parallel num_threads(threads)
    {
        // Contiguous blocks of an even number of rows (the kernel pairs rows).
        const int nth = omp_get_num_threads(), tid = omp_get_thread_num();
        const int pairs = (j1 - j0 + 1) / 2;
        const int a = j0 + 2 * (pairs * tid / nth);
        const int b = tid == nth - 1 ? j1 : j0 + 2 * (pairs * (tid + 1) / nth);
        if (b > a)
            bulk_update<T, Lossy>(u, up, un, s, i0, i1, a, b, c);
    }
}

template void bulk_update_threads<float, false>(const float *, const float *, float *, std::ptrdiff_t, int, int, int,
                                                int, const BulkCoefficients<float> &, int);
template void bulk_update_threads<float, true>(const float *, const float *, float *, std::ptrdiff_t, int, int, int,
                                               int, const BulkCoefficients<float> &, int);
template void bulk_update_threads<double, false>(const double *, const double *, double *, std::ptrdiff_t, int, int,
                                                 int, int, const BulkCoefficients<double> &, int);
template void bulk_update_threads<double, true>(const double *, const double *, double *, std::ptrdiff_t, int, int,
                                                int, int, const BulkCoefficients<double> &, int);

const char *bulk_update_isa()
{
    switch (isa_level()) {
    case 2: return "x86-64-v4 (AVX-512, 512-bit vectors)";
    case 1: return "x86-64-v3 (AVX2+FMA)";
    default: return "baseline";
    }
}

}  // namespace calib::engine
