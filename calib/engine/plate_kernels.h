// The hot loop: the 13-point bulk update of the interior (nodes two or more
// cells away from every edge), where every row of the operator is the same
// stencil. Near the edges the engine applies sparse rows instead.
//
// The state is the displacement u^n and the increment d^n = u^n - u^{n-1}
// (not u^{n-1}): leapfrog in increment form,
//   d^{n+1} = g d^n - mu2 L(L(u^n))  [+ nu1 L(d^n)]       (lossless: g = 1)
//   u^{n+1} = u^n + d^{n+1}
// with L the 5-point Laplacian times h^2, written as a sum of differences
// (u_east - u_c) + (u_west - u_c) + ...; L(L(.)) is exactly the 13-point
// biharmonic (20, -8, 2, 1). g = (1 - sigma0 k) / (1 + sigma0 k), mu2 =
// (kappa k / h^2)^2 and nu1 = 2 sigma1 k / h^2 scaled by 1 / (1 + sigma0 k)
// (plate_operator.h). The lossy kernel evaluates it as d^{n+1} = g d^n +
// L(W) with W = nu1 d^n - mu2 L(u^n) per node (the loss folded into the outer
// Laplacian: equal but for round-off). Algebraically this is the scheme u+ = 2u - u- - ..., with
// the same stability bound; in floating point it differs where it matters:
// - the displacement u enters only through differences of neighbours, which
//   are exact (Sterbenz) when a large rigid offset dominates, so the force a
//   drifting free plate feels carries round-off of the size of its strain,
//   not of its displacement;
// - the velocity is carried as d, rounded relative to itself, not re-formed
//   each step as the difference of two large rounded positions.
// Together they keep a free plate's rigid-body motion from feeding round-off
// back into its momentum (docs/engine.md, "Rigid-body modes in float").
// A constant or linear field has L = 0 exactly; no rounded coefficient like
// (2 - 20 mu^2) or 2 / (1 + sigma0 k) has to cancel against others (such a
// cancellation acts as a spurious spring of relative size eps / (omega k)^2).
#pragma once

#include <cstddef>
#include <cstdint>

namespace calib::engine {

// Clamped and simply supported edges as ghost mirrors (plate_engine.cpp): the
// boundary nodes i = 0, nx and j = 0, ny stay zero and the ghost beyond each is
// the first interior node's image, w_-1 = sign w_1 (+1 clamped, -1 supported).
template <typename T>
struct GhostMirrors {
    bool on = false;
    int nx = 0, ny = 0; // intervals; the nodes run 0 .. nx, 0 .. ny
    T left = 0, right = 0, bottom = 0, top = 0;
};

// The ghosts that mirror row j of u (E lanes per node, lanes.h): its two,
// and the ghost row below (j = 1) or above (j = ny - 1) the plate. The sweep
// calls it for each row it has just updated.
// `row`: where row j of u is held (a block's copy of a neighbour's row: see
// bulk_update_block); the ghost rows are u's.
template <typename T, int E = 1>
inline __attribute__((always_inline)) void refresh_ghosts(T *u, std::ptrdiff_t stride, int j, const GhostMirrors<T> &m,
                                                          T *row)
{
    if (!m.on)
        return;
    for (int l = 0; l < E; ++l) {
        row[-E + l] = m.left * row[E + l];
        row[(m.nx + 1) * E + l] = m.right * row[(m.nx - 1) * E + l];
    }
    if (j == 1)
        for (int q = -E; q < (m.nx + 2) * E; ++q)
            u[-stride + q] = m.bottom * row[q];
    if (j == m.ny - 1)
        for (int q = -E; q < (m.nx + 2) * E; ++q)
            u[(m.ny + 1) * stride + q] = m.top * row[q];
}
template <typename T, int E = 1>
inline __attribute__((always_inline)) void refresh_ghosts(T *u, std::ptrdiff_t stride, int j, const GhostMirrors<T> &m)
{
    refresh_ghosts<T, E>(u, stride, j, m, u + j * stride);
}

// Every ghost of u: the whole pass, for a field set or changed next to an
// edge outside the sweep.
template <typename T, int E = 1>
void mirror_ghosts(T *u, std::ptrdiff_t stride, const GhostMirrors<T> &m)
{
    for (int j = 0; j <= m.ny; ++j)
        refresh_ghosts<T, E>(u, stride, j, m);
}

template <typename T>
struct BulkCoefficients {
    T g;   // (1 - sigma0 k) / (1 + sigma0 k)
    T mu2; // (kappa k / h^2)^2 / (1 + sigma0 k)
    T nu1; // 2 sigma1 k / h^2 / (1 + sigma0 k) (only the lossy kernel reads it)
    // With mirrors on, the kernel's rows and columns must be all the unknowns
    // (i 1 .. nx-1, j 1 .. ny-1) and it refreshes the ghosts as it goes: each
    // row's two after the row is updated, the ghost rows after rows 1 and
    // ny - 1 (a ghost is read only before the row it mirrors is updated), so
    // the next step finds them set without a pass of its own.
    GhostMirrors<T> ghosts{};
};

// Rows are `stride` elements apart in all arrays (same layout). Updates rows
// [j0, j1) and columns [i0, i1) of u in place and writes d^{n+1} there into
// d_next; reads u two rows/columns beyond them and d (d^n, one beyond for the
// lossy kernel). `scratch` holds bulk_scratch_rows rows of `stride` elements
// (the Laplacian rows the sweep reuses). Loss is a compile-time choice: the
// lossless kernel never reads the neighbours of d. Dispatches at run time to
// the widest SIMD the CPU has (AVX-512, AVX2+FMA, baseline) where the compiler
// supports it. `phase`: both parts, or only the prologue (the Laplacian rows
// next to the block, read before a neighbouring block updates them in place)
// or only the sweep; bulk_update_threads runs every prologue before any sweep.
constexpr int bulk_scratch_rows = 5;
enum class BulkPhase { both, prologue, sweep };
template <typename T, bool Lossy>
void bulk_update(T *u, const T *d, T *d_next, std::ptrdiff_t stride, int i0, int i1, int j0, int j1,
                 const BulkCoefficients<T> &c, T *scratch, BulkPhase phase = BulkPhase::both);

// The first row of the t-th of `threads` contiguous blocks of rows [j0, j1)
// (t = threads: j1): how every threaded loop over the plate's rows cuts them,
// so each thread finds its rows in its own cache.
int block_seam(int j0, int j1, int threads, int t);

// The same, split into contiguous blocks of rows over `threads` OpenMP threads
// (one fork/join; 1 thread runs inline). scratch: threads * bulk_scratch_rows rows.
template <typename T, bool Lossy>
void bulk_update_threads(T *u, const T *d, T *d_next, std::ptrdiff_t stride, int i0, int i1, int j0, int j1,
                         const BulkCoefficients<T> &c, int threads, T *scratch);

// Several steps in one sweep (temporal blocking): each step's rows run two
// behind the step before it, so a row's u and d are read from memory once for
// all of them (where the grid outgrows the core's caches, a step otherwise
// streams u and d in and u and d^{n+1} out). u is updated in place by each
// step in turn; the increments of the levels between stay in three-row rings
// in `scratch` and never reach memory. On entry u = u^n and d = d^n; on
// return u = u^{n+steps} and d = d^{n+steps}; per step the arithmetic is
// bulk_update's, term for term. The rows j0 - 1 and j1 and the columns
// i0 - 1 and i1 are the boundary nodes of mirrored edges (zero in every
// level), the rows and columns are all the unknowns. `threads` > 1 cuts the
// rows into blocks over an OpenMP team, one fork/join per call and one
// barrier per sweep (plate_kernels.cpp: each block copies the 2 steps rows of
// u and d beyond each of its seams, then, after the barrier, runs a trapezoid
// in (row, step) that reaches into those copies far enough to finish its own
// rows); block_threads_fit() says whether the rows allow it. `blocks` > 1:
// that many sweeps of `steps` in a row in the one region, each block copying
// its rows for the next sweep at the end of its trapezoid into a second set
// of copies (the set its neighbours last read before the barrier before).
// After step m (1 .. blocks steps - 1) has updated row j (and its ghosts),
// `row_done(ctx, m, j, below)` is called, once per (m, j), from the thread
// that updated it (a sweep's last level: from the block that owns row j,
// after the barrier before the next sweep; only
// for the rows j with hook_rows[j] != 0, when hook_rows is given: a call
// clobbers the vector registers; on every row it cost 3-4 % of a block at
// 81 x 81 and 330 x 330): u rows
// j - 2 .. j hold u^{n+m} until the next step reaches row j - 2, where the
// u offsets in [below.first, below.last) are read at below.rows + (offset -
// below.first) (the block's copy of the rows under its lowest: their u^{n+m}
// is there, not in u). steps: 2 .. bulk_max_block_steps; scratch: threads *
// bulk_block_scratch_rows rows.
constexpr int bulk_max_block_steps = 4;
constexpr int bulk_block_scratch_rows = 3 * bulk_max_block_steps + 3 * (bulk_max_block_steps - 1) +
                                        2 * bulk_max_block_steps + 1 + 16 * bulk_max_block_steps;
constexpr int block_min_rows_per_thread = 8 * bulk_max_block_steps;
bool block_threads_fit(int j0, int j1, int threads);
struct BlockBelow {
    const void *rows = nullptr; // T
    std::ptrdiff_t first = 0, last = 0;
};
using BulkRowHook = void (*)(void *ctx, int level, int row, const BlockBelow &below);
// How many steps the next sweep takes (1 .. bulk_max_block_steps, at most
// `left`): steps m = 0, 1, ... join while no step but the last has a force
// (`forced(m)`, asked once each, in order) and nothing is due after any but
// the last (`due(m)`: a record, a lattice frame, a scan). Simulation::run
// and the lanes.
template <typename Forced, typename Due>
std::size_t block_length(std::size_t left, Forced &&forced, Due &&due)
{
    if (forced(0))
        return 1;
    std::size_t b = 1;
    while (b < std::size_t(bulk_max_block_steps) && b < left && !due(b - 1))
        if (forced(b++))
            break;
    return b;
}
// The whole-field scan for NaN and Inf (Simulation::run's) inside
// bulk_update_block's region: after block of steps b with after[b] != 0,
// each thread tests the nodes it updates, hot in its cache, and if any
// holds a non-finite value every thread stops after that block. Saves a
// parallel region of its own per scan, and lets a run of blocks go on past a
// scan. The boundary nodes are not tested: zero in every level, nothing
// writes them (a non-finite one would be read by the rows next to it).
struct BlockScan {
    const std::uint8_t *after = nullptr; // one per block of steps
    int blocks_done = 0;                 // out: the blocks run
    bool found = false;                  // out: the scan after the last block run saw a non-finite value
};
// The rows of a team's threads in bulk_update_block, and how long each
// worked: thread t takes rows [seam[t], seam[t + 1]) (seam[0] = j0 and
// seam[threads] = j1, each thread at least block_min_rows_per_thread rows;
// nullptr: block_seam's even cut), and busy_s[t], if given, receives its
// time in its sweeps, copies and scans, without the waits at the barriers.
// Any cut gives the same bits.
struct BlockTeam {
    const int *seam = nullptr;
    double *busy_s = nullptr;
};
// Moves a team's seams half-way towards rows in proportion to each thread's
// speed (its rows over its busy time), on the running sum rounded to rows,
// each thread keeping block_min_rows_per_thread rows; unchanged if a busy
// time is not positive. A core that shares its physical core with another
// guest's work runs a third slower for seconds at a time; an even cut then
// makes the other thread wait at every barrier.
void balance_seams(int *seam, const double *busy_s, int threads);
// E > 1: lanes (bulk_update_lanes' layout), one thread, no row_done.
template <typename T, bool Lossy, int E = 1>
void bulk_update_block(T *u, T *d, std::ptrdiff_t stride, int i0, int i1, int j0, int j1, const BulkCoefficients<T> &c,
                       int steps, int threads, T *scratch, BulkRowHook row_done, void *ctx,
                       const std::uint8_t *hook_rows = nullptr, int blocks = 1, BlockScan *scan = nullptr,
                       const BlockTeam *team = nullptr);

// Several independent fields of one plate side by side (engine/lanes.h): node
// (i, j) of lane l at u[j * stride + i * E + l], `stride` elements (a multiple
// of E) per row; otherwise as bulk_update, one thread, both phases. Per lane
// the arithmetic is bulk_update's, term for term.
template <typename T, bool Lossy, int E>
void bulk_update_lanes(T *u, const T *d, T *d_next, std::ptrdiff_t stride, int i0, int i1, int j0, int j1,
                       const BulkCoefficients<T> &c, T *scratch);

// Which instruction set the dispatcher picked (for the benchmark's report).
const char *bulk_update_isa();
// Run-time ISA dispatch of the kernels (this header's and edge_kernels.h's):
// GCC on x86-64, except sanitizer builds (HAPTIC_NO_TARGET_CLONES).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(HAPTIC_NO_TARGET_CLONES)
#define HAPTIC_DISPATCH 1
#endif
// The widest kernel set this CPU runs: 2 AVX-512, 1 AVX2+FMA, 0 baseline
// (always 0 where the build has no run-time dispatch).
int kernel_isa_level();

// Every hot loop is compiled the same way (-O3, CMake's haptic_kernel_sources):
// a function defined three times, with HAPTIC_ISA_AVX512, HAPTIC_ISA_AVX2 (only
// where HAPTIC_DISPATCH is defined) and no attribute, and the variant this CPU
// runs picked once by HAPTIC_PICK_ISA(function type, avx512, avx2, baseline).
#define HAPTIC_ISA_AVX512 __attribute__((target("arch=x86-64-v4,prefer-vector-width=512")))
#define HAPTIC_ISA_AVX2 __attribute__((target("arch=x86-64-v3")))
template <typename Fn>
Fn pick_isa(Fn avx512, Fn avx2, Fn baseline)
{
    switch (kernel_isa_level()) {
    case 2:
        return avx512;
    case 1:
        return avx2;
    default:
        return baseline;
    }
}
#ifdef HAPTIC_DISPATCH
#define HAPTIC_PICK_ISA(FN, AVX512, AVX2, BASELINE) ::calib::engine::pick_isa<FN>(AVX512, AVX2, BASELINE)
#else
#define HAPTIC_PICK_ISA(FN, AVX512, AVX2, BASELINE) FN(BASELINE)
#endif

} // namespace calib::engine
