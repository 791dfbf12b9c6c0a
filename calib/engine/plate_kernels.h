// The hot loop: the 13-point bulk update of the interior (nodes two or more
// cells away from every edge), where every row of the operator is the same
// stencil. Near the edges the engine applies sparse rows instead.
//
// Per node, with c = u(i,j), s1 = the 4 nearest neighbours, s2 = the 4
// diagonal ones, s3 = the 4 at distance 2, p = u^{n-1}(i,j), sp1 = the 4
// nearest neighbours of u^{n-1}:
//   lap2 = 20 c - 8 s1 + 2 s2 + s3          (h^4 times the biharmonic)
//   u^{n+1} = c + g (c - p) - mu2 lap2                          (lossless: g = 1)
//           ... + nu1 ((4 p - sp1) - (4 c - s1))                (lossy)
// with g = (1 - sigma0 k) / (1 + sigma0 k) and mu2, nu1 scaled by
// 1 / (1 + sigma0 k) (plate_operator.h). Written this way a constant field
// stays constant exactly, in float too: the integer weights are exact and no
// rounded coefficient like (2 - 20 mu^2) or 2 / (1 + sigma0 k) has to cancel
// against others. Such a cancellation error acts as a spurious spring of
// relative size eps / (omega k)^2: several % at 30 Hz in float with k ~ 4 us.
#pragma once

#include <cstddef>

namespace calib::engine {

template <typename T>
struct BulkCoefficients {
    T g;    // (1 - sigma0 k) / (1 + sigma0 k)
    T mu2;  // (kappa k / h^2)^2 / (1 + sigma0 k)
    T nu1;  // 2 sigma1 k / h^2 / (1 + sigma0 k) (only the lossy kernel reads it)
};

// Rows are `stride` elements apart in all three arrays (same layout). Updates
// rows [j0, j1) and columns [i0, i1); reads two rows/columns beyond them.
// Loss is a compile-time choice: the lossless kernel never touches q1 or the
// neighbours of u^{n-1}. Dispatches at run time to the widest SIMD the CPU
// has (AVX-512, AVX2+FMA, baseline) where the compiler supports it.
template <typename T, bool Lossy>
void bulk_update(const T *u, const T *u_prev, T *u_next, std::ptrdiff_t stride, int i0, int i1, int j0, int j1,
                 const BulkCoefficients<T> &c);

// The same, split into contiguous blocks of rows over `threads` OpenMP threads
// (one fork/join; 1 thread runs inline).
template <typename T, bool Lossy>
void bulk_update_threads(const T *u, const T *u_prev, T *u_next, std::ptrdiff_t stride, int i0, int i1, int j0,
                         int j1, const BulkCoefficients<T> &c, int threads);

// Which instruction set the dispatcher picked (for the benchmark's report).
const char *bulk_update_isa();

}  // namespace calib::engine
