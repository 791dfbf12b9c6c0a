// Cell updates per second of the plate scheme's bulk update (the hot loop),
// float and double, 1 and 2 threads, grids 64^2 .. 2048^2, and in the same run
// a deliberately plain reference: the straightforward 13-point loop with a
// flat index, compiled -O3 for the default target (and once more with the
// same run-time ISA dispatch as ours, so the ISA's share of the gain shows).
// Each of our benchmarks also reports `x_plain`: its rate over the plain
// loop's, measured in the same process on the same grid and precision.
//
//   build/h-engine-bench/bench/bench_plate --benchmark_min_time=0.2
#include "engine/plate_kernels.h"

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <random>
#include <utility>
#include <vector>

using namespace calib::engine;

namespace {

// Three time levels (the engine's u, d^n, d^{n+1}; the plain loop's u-, u,
// u+) and the kernel's scratch rows, rows padded to 64 bytes, random content.
template <typename T>
struct Levels {
    int n;
    std::ptrdiff_t stride;
    T *mem;
    T *a, *b, *c, *scratch;
    explicit Levels(int n_) : n(n_)
    {
        const std::ptrdiff_t per_line = 64 / sizeof(T);
        stride = (n + 1 + per_line - 1) / per_line * per_line;
        const std::size_t level = std::size_t(stride) * std::size_t(n + 1);
        const std::size_t total = 3 * level + std::size_t(2 * bulk_scratch_rows) * std::size_t(stride);
        mem = static_cast<T *>(std::aligned_alloc(64, total * sizeof(T)));
        std::mt19937 rng(1);
        std::uniform_real_distribution<double> u(-1, 1);
        for (std::size_t i = 0; i < total; ++i)
            mem[i] = T(u(rng));
        a = mem;
        b = mem + level;
        c = mem + 2 * level;
        scratch = mem + 3 * level;
    }
    // The engine's step: u (a) in place, d^n (b) read, d^{n+1} (c) written.
    void swap_increments() { std::swap(b, c); }
    ~Levels() { std::free(mem); }
    void rotate()
    {
        T *t = a;
        a = b;
        b = c;
        c = t;
    }
};

template <typename T>
BulkCoefficients<T> coefficients()
{
    const double mu2 = 0.24 * 0.24; // just inside mu = 1/4: stays bounded
    return {T(1), T(mu2), T(0)};
}

// The plain loop, as one would first write it.
template <typename T>
inline __attribute__((always_inline)) void plain_step(const T *u, const T *up, T *un, int n, std::ptrdiff_t s, T mu2)
{
    for (int j = 2; j <= n - 2; ++j)
        for (int i = 2; i <= n - 2; ++i) {
            const std::ptrdiff_t c = j * s + i;
            un[c] = 2 * u[c] - up[c] -
                    mu2 * (20 * u[c] - 8 * (u[c - 1] + u[c + 1] + u[c - s] + u[c + s]) +
                           2 * (u[c - s - 1] + u[c - s + 1] + u[c + s - 1] + u[c + s + 1]) + u[c - 2] + u[c + 2] +
                           u[c - 2 * s] + u[c + 2 * s]);
        }
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define BENCH_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define BENCH_CLONES
#endif
BENCH_CLONES void plain_step_isa_f(const float *u, const float *up, float *un, int n, std::ptrdiff_t s, float mu2)
{
    plain_step(u, up, un, n, s, mu2);
}
BENCH_CLONES void plain_step_isa_d(const double *u, const double *up, double *un, int n, std::ptrdiff_t s, double mu2)
{
    plain_step(u, up, un, n, s, mu2);
}

template <typename T>
double cells(int n)
{
    return double(n - 3) * double(n - 3);
}

// Plain-loop rate (cells/s) on a grid, timed for ~0.15 s.
template <typename T>
double plain_rate(int n)
{
    Levels<T> L(n);
    const T mu2 = T(0.24 * 0.24);
    int iters = 0;
    const auto t0 = std::chrono::steady_clock::now();
    double elapsed = 0;
    do {
        plain_step(L.b, L.a, L.c, n, L.stride, mu2);
        L.rotate();
        ++iters;
        elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } while (elapsed < 0.15);
    return iters * cells<T>(n) / elapsed;
}

template <typename T>
void BM_Bulk(benchmark::State &state)
{
    const int n = int(state.range(0));
    const int threads = int(state.range(1));
    const double plain = plain_rate<T>(n);
    Levels<T> L(n);
    const auto c = coefficients<T>();
    for (auto _ : state) {
        bulk_update_threads<T, false>(L.a, L.b, L.c, L.stride, 2, n - 1, 2, n - 1, c, threads, L.scratch);
        L.swap_increments();
        benchmark::ClobberMemory();
    }
    const double updated = double(state.iterations()) * cells<T>(n);
    state.counters["cells/s"] = benchmark::Counter(updated, benchmark::Counter::kIsRate);
    // (cells / plain rate) per second = our rate / plain rate
    state.counters["x_plain"] = benchmark::Counter(updated / plain, benchmark::Counter::kIsRate);
    state.SetLabel(bulk_update_isa());
}

template <typename T>
void BM_BulkLossy(benchmark::State &state)
{
    const int n = int(state.range(0));
    Levels<T> L(n);
    auto c = coefficients<T>();
    c.nu1 = T(1e-3);
    for (auto _ : state) {
        bulk_update_threads<T, true>(L.a, L.b, L.c, L.stride, 2, n - 1, 2, n - 1, c, 1, L.scratch);
        L.swap_increments();
        benchmark::ClobberMemory();
    }
    state.counters["cells/s"] =
        benchmark::Counter(double(state.iterations()) * cells<T>(n), benchmark::Counter::kIsRate);
}

template <typename T, bool SameIsa>
void BM_Plain(benchmark::State &state)
{
    const int n = int(state.range(0));
    Levels<T> L(n);
    const T mu2 = T(0.24 * 0.24);
    for (auto _ : state) {
        if constexpr (SameIsa) {
            if constexpr (sizeof(T) == 4)
                plain_step_isa_f(L.b, L.a, L.c, n, L.stride, mu2);
            else
                plain_step_isa_d(L.b, L.a, L.c, n, L.stride, mu2);
        } else {
            plain_step(L.b, L.a, L.c, n, L.stride, mu2);
        }
        L.rotate();
        benchmark::ClobberMemory();
    }
    state.counters["cells/s"] =
        benchmark::Counter(double(state.iterations()) * cells<T>(n), benchmark::Counter::kIsRate);
}

void grids_threads(benchmark::internal::Benchmark *b)
{
    for (int n : {64, 128, 256, 512, 1024, 2048})
        for (int t : {1, 2})
            b->Args({n, t});
}
void grids(benchmark::internal::Benchmark *b)
{
    for (int n : {64, 128, 256, 512, 1024, 2048})
        b->Args({n});
}

} // namespace

BENCHMARK(BM_Bulk<float>)->Apply(grids_threads)->UseRealTime();
BENCHMARK(BM_Bulk<double>)->Apply(grids_threads)->UseRealTime();
BENCHMARK(BM_Plain<float, false>)->Apply(grids)->UseRealTime();
BENCHMARK(BM_Plain<double, false>)->Apply(grids)->UseRealTime();
BENCHMARK(BM_Plain<float, true>)->Apply(grids)->UseRealTime();
BENCHMARK(BM_Plain<double, true>)->Apply(grids)->UseRealTime();
BENCHMARK(BM_BulkLossy<float>)->Apply(grids)->UseRealTime();
BENCHMARK(BM_BulkLossy<double>)->Apply(grids)->UseRealTime();

BENCHMARK_MAIN();
