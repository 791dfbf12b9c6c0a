#include "engine/plate_kernels.h"

#include "engine/non_finite.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <initializer_list>
#include <stdexcept>
#include <string>
#include <vector>

namespace calib::engine {

namespace {

// a * b + c: fused (one rounding) in the variants for CPUs with FMA, two
// roundings in the baseline. Written out, since this file is compiled
// without contraction (CMakeLists.txt): where the compiler fuses is its own
// choice per inlined copy and per vector or scalar path, and the single
// step, the blocks of steps and the lanes must round alike.
template <bool Fma, typename T>
inline __attribute__((always_inline)) T mul_add(T a, T b, T c)
{
    if constexpr (Fma)
        return std::fma(a, b, c);
    else
        return a * b + c;
}

// The ring holds, per row, what the sweep's second Laplacian takes:
// lossless, the Laplacian of u, L(u); lossy, the row's share of the whole
// right-hand side, W = nu1 d - mu2 L(u), so that d^{n+1} = g d + L(W) (the
// loss term folded into the biharmonic's outer Laplacian: one Laplacian
// fewer per node, and three loads of d^n's neighbours fewer). W is formed
// from differences as before: a field constant in u and d gives L(W) = 0
// exactly.
template <typename T, bool Lossy, bool Fma>
inline __attribute__((always_inline)) T ring_value(T lap_u, T d, const BulkCoefficients<T> &c)
{
    if constexpr (Lossy)
        return mul_add<Fma>(-c.mu2, lap_u, c.nu1 * d);
    else
        return lap_u;
}

// The ring value at node q of row r1 (rows r0 and r2 around it, E lanes per
// node): the one formula the sweep, the prologues and the blocks' first rows
// share, so they round alike.
template <typename T, bool Lossy, int E, bool Fma>
inline __attribute__((always_inline)) T ring_at(const T *r0, const T *r1, const T *r2, const T *d1, int q,
                                                const BulkCoefficients<T> &c)
{
    const T cc = r1[q];
    return ring_value<T, Lossy, Fma>(((r1[q - E] - cc) + (r1[q + E] - cc)) + ((r0[q] - cc) + (r2[q] - cc)), d1[q], c);
}

// One output row j of the sweep: the ring row j+1 (fresh, or read when the
// block's prologue made it), the second Laplacian from ring rows j-1, j,
// j+1, then d^{n+1} and u^{n+1} in place. u row j is read (for the Laplacian
// of row j+1) before it is written, in the same iteration; no later iteration
// reads it. No branches inside the i loop.
template <typename T, bool Lossy, bool Fresh, int E, bool Fma>
inline __attribute__((always_inline)) void output_row(T *__restrict u0, const T *__restrict u1, const T *__restrict u2,
                                                      const T *__restrict lm, const T *__restrict l0, T *__restrict lp,
                                                      const T *__restrict d0, const T *__restrict dp, T *__restrict dn,
                                                      int i0, int i1, const BulkCoefficients<T> &c)
{
    const T g = c.g, mu2 = c.mu2;
    if constexpr (Fresh) {
        // The two columns beyond the row (band columns: never written by the sweep).
        for (int i : {i0 - 1, i1})
            for (int q = i * E; q < (i + 1) * E; ++q)
                lp[q] = ring_at<T, Lossy, E, Fma>(u0, u1, u2, dp, q, c);
    }
    // q runs over the row's nodes and, within a node, its E lanes: the
    // horizontal neighbours are E elements away.
#pragma omp simd
    for (int q = i0 * E; q < i1 * E; ++q) {
        T lnext;
        if constexpr (Fresh) {
            lnext = ring_at<T, Lossy, E, Fma>(u0, u1, u2, dp, q, c);
            lp[q] = lnext;
        } else {
            lnext = lp[q];
        }
        // 4 l0 is exact: fused or not, the same bits.
        const T lap2 = mul_add<Fma>(T(-4), l0[q], (lm[q] + lnext) + (l0[q - E] + l0[q + E]));
        T v;
        if constexpr (Lossy)
            v = mul_add<Fma>(g, d0[q], lap2);
        else
            v = mul_add<Fma>(-mu2, lap2, g * d0[q]);
        dn[q] = v;
        u0[q] += v;
    }
}

template <typename T, bool Lossy, int E, bool Fma>
inline __attribute__((always_inline)) void ring_row(const T *__restrict r0, const T *__restrict r1,
                                                    const T *__restrict r2, const T *__restrict d1, T *__restrict out,
                                                    int lo, int hi, const BulkCoefficients<T> &c)
{
#pragma omp simd
    for (int q = lo * E; q < hi * E; ++q)
        out[q] = ring_at<T, Lossy, E, Fma>(r0, r1, r2, d1, q, c);
}

// Rows [a, b) of the block. The ring row (L(u) or W) is kept for three rows (a
// ring) plus rows b-1 and b, made in the prologue: they read u rows a-2 ..
// a+1 and b-2 .. b+1, which the neighbouring blocks update in place in their
// sweep, so with several threads every prologue must finish before any sweep
// starts (bulk_update_threads puts a barrier between them).
template <typename T>
inline T *laplacian_slot(T *scratch, std::ptrdiff_t s, int a, int b, int row)
{
    return row >= b - 1 ? scratch + (3 + row - (b - 1)) * s : scratch + ((row - a + 1) % 3) * s;
}

template <typename T, bool Lossy, int E, bool Fma>
inline __attribute__((always_inline)) void bulk_body(T *u, const T *d, T *dn, std::ptrdiff_t s, int i0, int i1, int a,
                                                     int b, const BulkCoefficients<T> &c, T *scratch, BulkPhase phase)
{
    if (b <= a)
        return;
    if (phase != BulkPhase::sweep)
        for (int row : {a - 1, a, b - 1, b})
            ring_row<T, Lossy, E, Fma>(u + (row - 1) * s, u + row * s, u + (row + 1) * s, d + row * s,
                                       laplacian_slot(scratch, s, a, b, row), i0 - 1, i1 + 1, c);
    if (phase == BulkPhase::prologue)
        return;
    for (int j = a; j < b; ++j) {
        T *u0 = u + j * s;
        const T *u1 = u0 + s, *u2 = u0 + 2 * s;
        const T *d0 = d + j * s;
        T *lm = laplacian_slot(scratch, s, a, b, j - 1), *l0 = laplacian_slot(scratch, s, a, b, j),
          *lp = laplacian_slot(scratch, s, a, b, j + 1);
        if (j + 1 < b - 1)
            output_row<T, Lossy, true, E, Fma>(u0, u1, u2, lm, l0, lp, d0, d0 + s, dn + j * s, i0, i1, c);
        else
            output_row<T, Lossy, false, E, Fma>(u0, u1, u2, lm, l0, lp, d0, d0 + s, dn + j * s, i0, i1, c);
        refresh_ghosts<T, E>(u, s, j, c.ghosts);
    }
}

// Several steps in one sweep (bulk_update_block). Step k (0 .. steps - 1)
// updates row j = t - 2 k at time t, after step k - 1 has updated row t - 2 (k - 1)
// = j + 2: it reads u^{n+k} rows j .. j + 2 (step k - 1 wrote them at t - 2 ..
// t; step k itself, two rows behind, has not yet reached them; row j is read
// before it is written) and the increment d^{n+k} rows j and j + 1, and
// writes d^{n+k+1} row j. The increments between the first level and the last
// live in rings of three rows (written at t, read at t + 1 and t + 2); the
// last step writes d^{n+steps} over d^n row j, which the first step last read
// at t - 2 (steps - 1).
//
// With several threads the rows are cut at seams into contiguous blocks, and
// each block is a trapezoid in (row, step) that overlaps its neighbours: to
// finish its own rows [a, b) in every step, step k must also update the 2
// (steps - 1 - k) rows beyond each seam (step k + 1's row reads step k's two
// rows beyond it), and those read u and d^n up to 2 steps rows beyond. A
// block works those rows on its own copies (`below`, `above`), taken before
// the barrier while every row still holds u^n and d^n, so no thread reads a
// row another updates: one barrier per block of steps, and each thread's
// rows and copies stay in its own cache. The rows beyond the seams are
// updated twice (by the block and on the neighbour's copy): 2 steps (steps -
// 1) row-steps per seam, 24 of 1,320 per block of four steps at 330 x 330.
constexpr int block_max = bulk_max_block_steps;
template <typename T>
struct BlockRegion {
    int steps = 0;
    std::array<int, block_max> lo{}, hi{}; // rows of step k, beyond [a, b) on the copies
    int a = 0, b = 0;                      // this block's own rows
    int level0 = 0;                        // row_done's level of this block's start
    // This thread's scratch: ring 3 rows per step, inc 3 per level between,
    // start 2 per step, one zero row, the copies of the 2 steps rows below a
    // and from b (u and d each; nullptr at j0 and j1).
    T *ring = nullptr, *inc = nullptr, *start = nullptr, *zero = nullptr;
    T *below_u = nullptr, *below_d = nullptr, *above_u = nullptr, *above_d = nullptr;
    int below_first() const { return a - 2 * steps; }
};

template <typename T>
BlockRegion<T> block_scratch(T *scratch, std::ptrdiff_t s, int set)
{
    BlockRegion<T> r;
    r.ring = scratch;
    r.inc = r.ring + 3 * block_max * s;
    r.start = r.inc + 3 * (block_max - 1) * s;
    r.zero = r.start + 2 * block_max * s;
    r.below_u = r.zero + s + std::ptrdiff_t(set) * 8 * block_max * s;
    r.below_d = r.below_u + 2 * block_max * s;
    r.above_u = r.below_d + 2 * block_max * s;
    r.above_d = r.above_u + 2 * block_max * s;
    return r;
}

// Steps: r.steps as a constant, so the loop over the steps can unroll
// (measured within the noise of a run-time count at 81 x 81).
template <typename T, bool Lossy, int E, bool Fma, int Steps>
inline __attribute__((always_inline)) void block_body(T *u, T *d, std::ptrdiff_t s, int i0, int i1, int j0, int j1,
                                                      const BulkCoefficients<T> &c, const BlockRegion<T> &r,
                                                      BulkRowHook row_done, void *ctx, const std::uint8_t *hook_rows)
{
    constexpr int steps = Steps;
    // Where row `row` of u and of d^n is held: beyond the block's own rows,
    // on its copies.
    auto held = [&](T * field, T * below, T * above, int row) __attribute__((always_inline))->T *
    {
        if (row < r.a && below)
            return below + (row - r.below_first()) * s;
        if (row >= r.b && above)
            return above + (row - r.b) * s;
        return field + row * s;
    };
    auto urow = [&](int row) __attribute__((always_inline)) { return held(u, r.below_u, r.above_u, row); };
    auto ring = [&](int k, int row) __attribute__((always_inline))->T *
    {
        if (row <= r.lo[k])
            return r.start + (2 * k + row - r.lo[k] + 1) * s;
        return r.ring + (3 * k + row % 3) * s;
    };
    auto inc = [&](int k, int row) __attribute__((always_inline))->T *
    { // d^{n+k}, row `row`
        if (k == 0 || k == steps)
            return held(d, r.below_d, r.above_d, row);
        if (row < j0 || row >= j1)
            return r.zero; // never written
        return r.inc + (3 * (k - 1) + row % 3) * s;
    };
    auto start_ring = [&](int k) __attribute__((always_inline))
    {
        for (int row : {r.lo[k] - 1, r.lo[k]})
            ring_row<T, Lossy, E, Fma>(urow(row - 1), urow(row), urow(row + 1), inc(k, row), ring(k, row), i0 - 1,
                                       i1 + 1, c);
    };
    const BlockBelow below =
        r.below_u ? BlockBelow{r.below_u, r.below_first() * s, std::ptrdiff_t(r.a) * s} : BlockBelow{};
    int t0 = r.lo[0], t1 = r.hi[0];
    for (int k = 0; k < steps; ++k)
        if (r.hi[k] > r.lo[k]) {
            t0 = std::min(t0, r.lo[k] + 2 * k);
            t1 = std::max(t1, r.hi[k] + 2 * k);
        }
    start_ring(0);
    // Per step, the ring rows j - 1 and j and the increment row j of the row
    // at hand, carried from row to row (a row then maps one ring row and two
    // increment rows; no difference was measured against mapping all six).
    std::array<T *, block_max> lm{}, l0{}, d0{};
    for (int t = t0; t < t1; ++t)
        for (int k = 0; k < steps; ++k) {
            const int j = t - 2 * k;
            if (j < r.lo[k] || j >= r.hi[k])
                continue;
            const std::size_t kk = std::size_t(k);
            if (j == r.lo[k]) {
                lm[kk] = ring(k, j - 1);
                l0[kk] = ring(k, j);
                d0[kk] = inc(k, j);
            }
            T *const lp = ring(k, j + 1), *const dp = inc(k, j + 1);
            T *const uj = urow(j);
            output_row<T, Lossy, true, E, Fma>(uj, urow(j + 1), urow(j + 2), lm[kk], l0[kk], lp, d0[kk], dp,
                                               inc(k + 1, j), i0, i1, c);
            lm[kk] = l0[kk];
            l0[kk] = lp;
            d0[kk] = dp;
            refresh_ghosts<T, E>(u, s, j, c.ghosts, uj);
            if (k + 1 < steps) {
                if (row_done && j >= r.a && j < r.b && (!hook_rows || hook_rows[j]))
                    row_done(ctx, r.level0 + k + 1, j, below);
                // Step k + 1's first two Laplacian rows, once u^{n+k+1} rows
                // lo - 2 .. lo + 1 are there (and before its first row).
                if (j == std::min(r.lo[k + 1] + 1, r.hi[k] - 1))
                    start_ring(k + 1);
            }
        }
}

} // namespace

// Run-time ISA dispatch: the same body compiled for AVX-512 (with 512-bit
// vectors: GCC otherwise prefers 256-bit ones on x86-64-v4), AVX2+FMA and the
// baseline, chosen once from the CPU. Sanitizer builds keep the baseline only.

template <typename T>
using BulkFn = void (*)(T *, const T *, T *, std::ptrdiff_t, int, int, int, int, const BulkCoefficients<T> &, T *,
                        BulkPhase);

#define HAPTIC_BULK_VARIANT(NAME, ATTR, FMA)                                                                           \
    template <typename T, bool Lossy, int E>                                                                           \
    ATTR void NAME(T *u, const T *d, T *dn, std::ptrdiff_t s, int i0, int i1, int j0, int j1,                          \
                   const BulkCoefficients<T> &c, T *scratch, BulkPhase phase)                                          \
    {                                                                                                                  \
        bulk_body<T, Lossy, E, FMA>(u, d, dn, s, i0, i1, j0, j1, c, scratch, phase);                                   \
    }

HAPTIC_BULK_VARIANT(bulk_baseline, , false)
#ifdef HAPTIC_DISPATCH
HAPTIC_BULK_VARIANT(bulk_avx512, HAPTIC_ISA_AVX512, true)
HAPTIC_BULK_VARIANT(bulk_avx2, HAPTIC_ISA_AVX2, true)
#endif

template <typename T>
using BlockFn = void (*)(T *, T *, std::ptrdiff_t, int, int, int, int, const BulkCoefficients<T> &,
                         const BlockRegion<T> &, BulkRowHook, void *, const std::uint8_t *);

#define HAPTIC_BLOCK_VARIANT(NAME, ATTR, FMA)                                                                          \
    template <typename T, bool Lossy, int E>                                                                           \
    ATTR void NAME(T *u, T *d, std::ptrdiff_t s, int i0, int i1, int j0, int j1, const BulkCoefficients<T> &c,         \
                   const BlockRegion<T> &r, BulkRowHook row_done, void *ctx, const std::uint8_t *rows)                 \
    {                                                                                                                  \
        if (r.steps == 2)                                                                                              \
            block_body<T, Lossy, E, FMA, 2>(u, d, s, i0, i1, j0, j1, c, r, row_done, ctx, rows);                       \
        else if (r.steps == 3)                                                                                         \
            block_body<T, Lossy, E, FMA, 3>(u, d, s, i0, i1, j0, j1, c, r, row_done, ctx, rows);                       \
        else                                                                                                           \
            block_body<T, Lossy, E, FMA, 4>(u, d, s, i0, i1, j0, j1, c, r, row_done, ctx, rows);                       \
    }

HAPTIC_BLOCK_VARIANT(block_baseline, , false)
#ifdef HAPTIC_DISPATCH
HAPTIC_BLOCK_VARIANT(block_avx512, HAPTIC_ISA_AVX512, true)
HAPTIC_BLOCK_VARIANT(block_avx2, HAPTIC_ISA_AVX2, true)
#endif

int kernel_isa_level()
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

namespace {

template <typename T, bool Lossy, int E>
BulkFn<T> select_bulk()
{
    return HAPTIC_PICK_ISA(BulkFn<T>, (bulk_avx512<T, Lossy, E>), (bulk_avx2<T, Lossy, E>),
                           (bulk_baseline<T, Lossy, E>));
}

} // namespace

template <typename T, bool Lossy>
void bulk_update(T *u, const T *d, T *dn, std::ptrdiff_t s, int i0, int i1, int j0, int j1,
                 const BulkCoefficients<T> &c, T *scratch, BulkPhase phase)
{
    static const BulkFn<T> fn = select_bulk<T, Lossy, 1>();
    fn(u, d, dn, s, i0, i1, j0, j1, c, scratch, phase);
}

int block_seam(int j0, int j1, int threads, int t) { return j0 + int(std::ptrdiff_t(j1 - j0) * t / threads); }

void balance_seams(int *seam, const double *busy_s, int threads)
{
    const int min_rows = block_min_rows_per_thread;
    if (threads < 2 || seam[threads] - seam[0] < threads * min_rows)
        return;
    double sum = 0;
    for (int t = 0; t < threads; ++t) {
        if (!(busy_s[t] > 0))
            return;
        sum += (seam[t + 1] - seam[t]) / busy_s[t];
    }
    // Half-way from each thread's rows to its share at its speed, rounded
    // on the running sum, then each kept min_rows from its neighbours.
    const int total = seam[threads] - seam[0];
    double at = seam[0];
    std::vector<int> next(std::size_t(threads) + 1, seam[0]);
    next[std::size_t(threads)] = seam[threads];
    for (int t = 0; t + 1 < threads; ++t) {
        const double rows = seam[t + 1] - seam[t], share = total * (rows / busy_s[t]) / sum;
        at += rows + 0.5 * (share - rows);
        next[std::size_t(t) + 1] = int(std::lround(at));
    }
    for (int t = 1; t < threads; ++t)
        next[std::size_t(t)] = std::max(next[std::size_t(t)], next[std::size_t(t) - 1] + min_rows);
    for (int t = threads - 1; t >= 1; --t)
        next[std::size_t(t)] = std::min(next[std::size_t(t)], next[std::size_t(t) + 1] - min_rows);
    std::copy(next.begin(), next.end(), seam);
}

bool block_threads_fit(int j0, int j1, int threads)
{
    return threads <= 1 || (j1 - j0) / threads >= block_min_rows_per_thread;
}

template <typename T, bool Lossy, int E>
void bulk_update_block(T *u, T *d, std::ptrdiff_t s, int i0, int i1, int j0, int j1, const BulkCoefficients<T> &c,
                       int steps, int threads, T *scratch, BulkRowHook row_done, void *ctx,
                       const std::uint8_t *hook_rows, int blocks, BlockScan *scan, const BlockTeam *team)
{
    static const BlockFn<T> fn = HAPTIC_PICK_ISA(BlockFn<T>, (block_avx512<T, Lossy, E>), (block_avx2<T, Lossy, E>),
                                                 (block_baseline<T, Lossy, E>));
    if (steps < 2 || steps > bulk_max_block_steps)
        throw std::invalid_argument("bulk_update_block: steps must be 2 .. " + std::to_string(bulk_max_block_steps));
    if (blocks < 1)
        throw std::invalid_argument("bulk_update_block: blocks must be >= 1");
    const int *const seams = team ? team->seam : nullptr;
    if (seams) {
        bool fit = seams[0] == j0 && seams[std::max(1, threads)] == j1;
        for (int t = 0; t < threads && fit; ++t)
            fit = seams[t + 1] - seams[t] >= (threads > 1 ? block_min_rows_per_thread : 0);
        if (!fit)
            throw std::invalid_argument("bulk_update_block: the seams must cut rows j0 .. j1 in order, each thread " +
                                        std::to_string(block_min_rows_per_thread) + " rows or more");
    } else if (!block_threads_fit(j0, j1, threads))
        throw std::invalid_argument("bulk_update_block: too few rows per thread");
    if (scan) {
        scan->blocks_done = 0;
        scan->found = false;
    }
    threads = std::max(1, threads);
    double *const busy = team ? team->busy_s : nullptr;
    if (busy)
        std::fill_n(busy, threads, 0.0);
    if (j1 <= j0)
        return;
    // The first row of block t (t = threads: j1).
    auto seam = [&](int t) { return seams ? seams[t] : block_seam(j0, j1, threads, t); };
    // Whether block t's rows of u hold a non-finite value, if a scan is due
    // after block of steps `blk`.
    auto scan_finds = [&](int t, int blk) {
        if (!scan || !scan->after[blk])
            return false;
        for (int j = seam(t); j < seam(t + 1); ++j)
            if (any_non_finite(u + j * s + i0 * E, long(i1 - i0) * E))
                return true;
        return false;
    };
    // The first block of steps after which a scan saw a non-finite value
    // (`blocks`: none).
    auto finish = [&](int stop) {
        if (scan) {
            scan->blocks_done = stop < blocks ? stop + 1 : blocks;
            scan->found = stop < blocks;
        }
    };
    // Block t's region in block of steps `blk`: its copies are the set of
    // blk's parity.
    auto region = [&](int t, int blk) {
        BlockRegion<T> r = block_scratch(scratch + std::ptrdiff_t(t) * bulk_block_scratch_rows * s, s, blk % 2);
        r.steps = steps;
        r.level0 = blk * steps;
        r.a = seam(t);
        r.b = seam(t + 1);
        if (t == 0)
            r.below_u = r.below_d = nullptr;
        if (t + 1 == threads)
            r.above_u = r.above_d = nullptr;
        for (int k = 0; k < steps; ++k) {
            const int beyond = 2 * (steps - 1 - k);
            r.lo[std::size_t(k)] = r.below_u ? r.a - beyond : r.a;
            r.hi[std::size_t(k)] = r.above_u ? r.b + beyond : r.b;
        }
        return r;
    };
    // The receivers of the level a block of steps starts from (the one
    // before's last), rows [r.a, r.b), read as the kernel reads them.
    auto start_level_done = [&](const BlockRegion<T> &r) {
        if (!row_done || r.level0 == 0)
            return;
        const BlockBelow below =
            r.below_u ? BlockBelow{r.below_u, r.below_first() * s, std::ptrdiff_t(r.a) * s} : BlockBelow{};
        for (int j = r.a; j < r.b; ++j)
            if (!hook_rows || hook_rows[j])
                row_done(ctx, r.level0, j, below);
    };
    if (threads == 1) {
        const double start = busy ? omp_get_wtime() : 0;
        int stop = blocks;
        for (int blk = 0; blk < blocks && stop == blocks; ++blk) {
            const BlockRegion<T> r = region(0, blk);
            start_level_done(r);
            fn(u, d, s, i0, i1, j0, j1, c, r, row_done, ctx, hook_rows);
            if (scan_finds(0, blk))
                stop = blk;
        }
        if (busy)
            busy[0] = omp_get_wtime() - start;
        return finish(stop);
    }
    // Rows `first` .. first + 2 steps - 1 of u and d to `u_copy`, `d_copy`
    // (columns i0 - 2 .. i1 + 1: the ghosts and the boundary columns the
    // stencil reads).
    auto copy_rows = [&](int first, T *u_copy, T *d_copy) {
        const std::ptrdiff_t from = first * s + i0 - 2, n = (2 * steps - 1) * s + (i1 - i0 + 4);
        std::copy_n(u + from, n, u_copy + (i0 - 2));
        std::copy_n(d + from, n, d_copy + (i0 - 2));
    };
    // Block t's own rows beside its seams to its neighbours' copies for block
    // of steps `blk`.
    auto copy_out = [&](int t, int blk) {
        const BlockRegion<T> r = region(t, blk);
        if (t > 0) {
            const BlockRegion<T> below = region(t - 1, blk);
            copy_rows(r.a, below.above_u, below.above_d);
        }
        if (t + 1 < threads) {
            const BlockRegion<T> above = region(t + 1, blk);
            copy_rows(above.below_first(), above.below_u, above.below_d);
        }
    };
    std::atomic<int> stop{blocks};
#pragma omp parallel num_threads(threads)
    {
        // A team smaller than asked (nested, or limited) runs several blocks
        // per thread: every copy is taken before any block runs.
        const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
        // Each block copies its own rows beside a seam to its neighbour: read
        // where they were written, so no other core holds a line of them
        // when this block next writes them (a neighbour reading them itself
        // left them shared, and every write to them in the sweep then waited
        // for the other core: measured 10-20 % slower per block, 330 x 330).
        double mark = busy ? omp_get_wtime() : 0;
        for (int t = tid; t < threads; t += nth)
            copy_out(t, 0);
        // Blocks of steps after the first: each block copies its rows at the
        // end of its trapezoid into the other set of copies, which its
        // neighbours last read before the barrier before; one barrier per
        // block of steps. After a scan that saw a non-finite value, every
        // thread leaves at the barrier after it.
        // Each thread's time is counted for its blocks (a team smaller than
        // asked: the first of them).
        for (int blk = 0; blk < blocks; ++blk) {
            if (busy)
                busy[tid] += omp_get_wtime() - mark;
#pragma omp barrier
            if (busy)
                mark = omp_get_wtime();
            if (stop.load(std::memory_order_relaxed) < blk)
                break;
            for (int t = tid; t < threads; t += nth) {
                // The copies, now in the other core's cache, asked for at once
                // rather than row by row as the sweep reaches them.
                const BlockRegion<T> r = region(t, blk);
                for (const T *p : {r.below_u, r.below_d, r.above_u, r.above_d})
                    if (p)
                        for (std::ptrdiff_t o = i0 - 2; o < 2 * steps * s; o += 64 / std::ptrdiff_t(sizeof(T)))
                            __builtin_prefetch(p + o, 0, 2);
                start_level_done(r);
                fn(u, d, s, i0, i1, j0, j1, c, r, row_done, ctx, hook_rows);
                if (blk + 1 < blocks)
                    copy_out(t, blk + 1);
                if (scan_finds(t, blk))
                    stop.store(blk, std::memory_order_relaxed);
            }
        }
        if (busy)
            busy[tid] += omp_get_wtime() - mark;
    }
    finish(stop.load(std::memory_order_relaxed));
}

template <typename T, bool Lossy, int E>
void bulk_update_lanes(T *u, const T *d, T *dn, std::ptrdiff_t s, int i0, int i1, int j0, int j1,
                       const BulkCoefficients<T> &c, T *scratch)
{
    static const BulkFn<T> fn = select_bulk<T, Lossy, E>();
    fn(u, d, dn, s, i0, i1, j0, j1, c, scratch, BulkPhase::both);
}

template <typename T, bool Lossy>
void bulk_update_threads(T *u, const T *d, T *dn, std::ptrdiff_t s, int i0, int i1, int j0, int j1,
                         const BulkCoefficients<T> &c, int threads, T *scratch)
{
    if (threads <= 1) {
        bulk_update<T, Lossy>(u, d, dn, s, i0, i1, j0, j1, c, scratch);
        return;
    }
#pragma omp parallel num_threads(threads)
    {
        // Contiguous blocks of rows: every block's prologue reads the rows
        // next to it before any sweep updates them in place.
        const int nth = omp_get_num_threads(), tid = omp_get_thread_num();
        const int a = block_seam(j0, j1, nth, tid), b = block_seam(j0, j1, nth, tid + 1);
        T *mine = scratch + std::ptrdiff_t(tid) * bulk_scratch_rows * s;
        bulk_update<T, Lossy>(u, d, dn, s, i0, i1, a, b, c, mine, BulkPhase::prologue);
#pragma omp barrier
        bulk_update<T, Lossy>(u, d, dn, s, i0, i1, a, b, c, mine, BulkPhase::sweep);
    }
}

#define HAPTIC_BULK_INSTANCES(T, L)                                                                                    \
    template void bulk_update<T, L>(T *, const T *, T *, std::ptrdiff_t, int, int, int, int,                           \
                                    const BulkCoefficients<T> &, T *, BulkPhase);                                      \
    template void bulk_update_threads<T, L>(T *, const T *, T *, std::ptrdiff_t, int, int, int, int,                   \
                                            const BulkCoefficients<T> &, int, T *);                                    \
    template void bulk_update_block<T, L, 1>(T *, T *, std::ptrdiff_t, int, int, int, int,                             \
                                             const BulkCoefficients<T> &, int, int, T *, BulkRowHook, void *,          \
                                             const std::uint8_t *, int, BlockScan *, const BlockTeam *);
#define HAPTIC_LANES_INSTANCES(T, L)                                                                                   \
    template void bulk_update_lanes<T, L, 1>(T *, const T *, T *, std::ptrdiff_t, int, int, int, int,                  \
                                             const BulkCoefficients<T> &, T *);                                        \
    template void bulk_update_lanes<T, L, 2>(T *, const T *, T *, std::ptrdiff_t, int, int, int, int,                  \
                                             const BulkCoefficients<T> &, T *);                                        \
    template void bulk_update_lanes<T, L, 4>(T *, const T *, T *, std::ptrdiff_t, int, int, int, int,                  \
                                             const BulkCoefficients<T> &, T *);                                        \
    template void bulk_update_lanes<T, L, 8>(T *, const T *, T *, std::ptrdiff_t, int, int, int, int,                  \
                                             const BulkCoefficients<T> &, T *);                                        \
    template void bulk_update_block<T, L, 2>(T *, T *, std::ptrdiff_t, int, int, int, int,                             \
                                             const BulkCoefficients<T> &, int, int, T *, BulkRowHook, void *,          \
                                             const std::uint8_t *, int, BlockScan *, const BlockTeam *);               \
    template void bulk_update_block<T, L, 4>(T *, T *, std::ptrdiff_t, int, int, int, int,                             \
                                             const BulkCoefficients<T> &, int, int, T *, BulkRowHook, void *,          \
                                             const std::uint8_t *, int, BlockScan *, const BlockTeam *);               \
    template void bulk_update_block<T, L, 8>(T *, T *, std::ptrdiff_t, int, int, int, int,                             \
                                             const BulkCoefficients<T> &, int, int, T *, BulkRowHook, void *,          \
                                             const std::uint8_t *, int, BlockScan *, const BlockTeam *);
HAPTIC_LANES_INSTANCES(float, false)
HAPTIC_LANES_INSTANCES(float, true)
HAPTIC_LANES_INSTANCES(double, false)
HAPTIC_LANES_INSTANCES(double, true)
HAPTIC_BULK_INSTANCES(float, false)
HAPTIC_BULK_INSTANCES(float, true)
HAPTIC_BULK_INSTANCES(double, false)
HAPTIC_BULK_INSTANCES(double, true)

const char *bulk_update_isa()
{
    switch (kernel_isa_level()) {
    case 2:
        return "x86-64-v4 (AVX-512, 512-bit vectors)";
    case 1:
        return "x86-64-v3 (AVX2+FMA)";
    default:
        return "baseline";
    }
}

} // namespace calib::engine
