// `calibgen simulate` end to end against a plain loop doing the same job:
// the Fig. 7 acrylic plate (0.7 x 0.7 m, 2 mm, clamped, the Fig. 7 loss) on
// n x n intervals, float or double, one impulse source, one receiver read every step,
// `steps` steps. Ours: engine::Simulation, timed from its construction
// (operator assembly, stability bound) to the last trace sample. The plain
// loop: the lossy leapfrog (13-point biharmonic, sigma0 and sigma1 terms)
// over a field with two ghost rows and columns, the clamped edge as the
// ghosts' mirror image, the source added and the receiver read in the loop;
// compiled with the same flags and the same run-time ISA dispatch as our
// kernels (GCC target clones: AVX-512, AVX2+FMA, baseline). The two are
// timed in alternating rounds in one process, fastest round of each (the
// machine is shared). Reports x_plain (plain time / ours) per grid and
// thread count, and the share of ours spent before the first step.
//
//   build/bench/bench/bench_simulate [--benchmark_filter=...]
#include "engine/lanes.h"
#include "engine/plate_kernels.h"
#include "engine/simulation.h"
#include "io/heap.h"
#include "pipeline/placement/site_recording.h"
#include "physics/material.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <vector>

using namespace calib::engine;

namespace {

// The heap as calibgen keeps it (io/heap.h), for every benchmark here.
[[maybe_unused]] const bool heap_kept = (calib::io::keep_freed_heap(), true);

constexpr double side_m = 0.7;

PlateParams fig7_plate()
{
    PlateParams p;
    p.size_x_m = side_m;
    p.size_y_m = side_m;
    p.thickness_m = 0.002;
    p.material = calib::physics::material_from_elastic(1200, 4.76e9, 0.38, "acrylic");
    p.edges = Edges::all(EdgeKind::clamped);
    // Fig. 7's two-point law (T60 0.54 s at 100 Hz, 0.18 s at 300 Hz) as sigma0 + sigma1 omega / kappa.
    const double kappa = std::sqrt(p.material.youngs_pa * p.thickness_m * p.thickness_m /
                                   (12 * p.material.density_kg_m3 * (1 - p.material.poisson * p.material.poisson)));
    const double r1 = 3 * std::log(10.0) / 0.54, r2 = 3 * std::log(10.0) / 0.18;
    const double w1 = 2 * M_PI * 100, w2 = 2 * M_PI * 300;
    p.loss.sigma1 = (r2 - r1) / ((w2 - w1) / kappa);
    p.loss.sigma0 = r1 - p.loss.sigma1 * w1 / kappa;
    return p;
}

struct Job {
    int n;
    std::size_t steps;
    int threads;
    bool f64 = false; // double precision (ours and the plain loop)
};

// Ours, end to end; returns the seconds and the setup's share.
double run_ours(const Job &job, double &setup_s, double &checksum)
{
    const auto t0 = std::chrono::steady_clock::now();
    const double h = side_m / job.n;
    auto op = std::make_shared<PlateOperator>(fig7_plate(), Grid{job.n, job.n, h});
    SimulationOptions o;
    o.precision = job.f64 ? Precision::f64 : Precision::f32;
    o.engine.threads = job.threads;
    Simulation sim(op, o);
    sim.add_source(0.3 * side_m, 0.41 * side_m);
    sim.add_receiver(0.62 * side_m, 0.55 * side_m);
    sim.set_source_impulse(0);
    setup_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sim.run(job.steps);
    checksum = sim.traces()[0].back();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The plain loop's step over (n + 5)^2 nodes: two ghost layers, node (i, j)
// of the plate at index (j + 2) s + i + 2; the boundary nodes stay zero.
template <typename T>
inline __attribute__((always_inline)) void plain_lossy_step(const T *u, const T *up, T *un, int n, std::ptrdiff_t s,
                                                            T mu2, T nu1, T a, T b)
{
    for (int j = 3; j <= n + 1; ++j)
        for (int i = 3; i <= n + 1; ++i) {
            const std::ptrdiff_t c = j * s + i;
            const T bih = 20 * u[c] - 8 * (u[c - 1] + u[c + 1] + u[c - s] + u[c + s]) +
                          2 * (u[c - s - 1] + u[c - s + 1] + u[c + s - 1] + u[c + s + 1]) + u[c - 2] + u[c + 2] +
                          u[c - 2 * s] + u[c + 2 * s];
            const T lap = u[c - 1] + u[c + 1] + u[c - s] + u[c + s] - 4 * u[c];
            const T lapp = up[c - 1] + up[c + 1] + up[c - s] + up[c + s] - 4 * up[c];
            un[c] = a * (2 * u[c] - mu2 * bih + nu1 * (lap - lapp)) - b * up[c];
        }
}

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__)
#define BENCH_CLONES __attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#else
#define BENCH_CLONES
#endif
BENCH_CLONES void plain_lossy_step_isa(const float *u, const float *up, float *un, int n, std::ptrdiff_t s, float mu2,
                                       float nu1, float a, float b)
{
    plain_lossy_step(u, up, un, n, s, mu2, nu1, a, b);
}
BENCH_CLONES void plain_lossy_step_isa(const double *u, const double *up, double *un, int n, std::ptrdiff_t s,
                                       double mu2, double nu1, double a, double b)
{
    plain_lossy_step(u, up, un, n, s, mu2, nu1, a, b);
}

// Clamped: w = 0 on the boundary, the ghost beyond it the mirror of the first interior node.
template <typename T>
void clamp_ghosts(T *u, int n, std::ptrdiff_t s)
{
    for (int k = 2; k <= n + 2; ++k) {
        u[k * s + 1] = u[k * s + 3];
        u[k * s + n + 3] = u[k * s + n + 1];
        u[1 * s + k] = u[3 * s + k];
        u[(n + 3) * s + k] = u[(n + 1) * s + k];
    }
}

template <typename T>
double run_plain_as(const Job &job, double k, double &checksum)
{
    const auto t0 = std::chrono::steady_clock::now();
    const PlateParams p = fig7_plate();
    const int n = job.n;
    const double h = side_m / n;
    const double kappa = std::sqrt(p.material.youngs_pa * p.thickness_m * p.thickness_m /
                                   (12 * p.material.density_kg_m3 * (1 - p.material.poisson * p.material.poisson)));
    const double d = 1 / (1 + p.loss.sigma0 * k);
    const auto mu2 = T(kappa * kappa * k * k / (h * h * h * h));
    const auto nu1 = T(2 * p.loss.sigma1 * k / (h * h));
    const auto a = T(d), b = T(d * (1 - p.loss.sigma0 * k));
    const std::ptrdiff_t s = (n + 5 + 15) / 16 * 16;
    const std::size_t level = std::size_t(s) * std::size_t(n + 5);
    std::vector<T> mem(3 * level, T(0));
    T *up = mem.data(), *u = up + level, *un = u + level;
    const std::ptrdiff_t src = std::ptrdiff_t(std::lround(0.41 * n) + 2) * s + std::lround(0.3 * n) + 2;
    const std::ptrdiff_t rec = std::ptrdiff_t(std::lround(0.55 * n) + 2) * s + std::lround(0.62 * n) + 2;
    const auto kick = T(k * k / (p.material.density_kg_m3 * p.thickness_m * h * h) / k);
    std::vector<double> trace;
    trace.reserve(job.steps);
    for (std::size_t t = 0; t < job.steps; ++t) {
        plain_lossy_step_isa(u, up, un, n, s, mu2, nu1, a, b);
        if (t == 0)
            un[src] += kick;
        clamp_ghosts(un, n, s);
        trace.push_back(un[rec]);
        T *old = up;
        up = u;
        u = un;
        un = old;
    }
    checksum = trace.back();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double run_plain(const Job &job, double k, double &checksum)
{
    return job.f64 ? run_plain_as<double>(job, k, checksum) : run_plain_as<float>(job, k, checksum);
}

void BM_SimulateEndToEnd(benchmark::State &state)
{
    const Job job{int(state.range(0)), std::size_t(state.range(1)), int(state.range(2)), state.range(3) != 0};
    double setup = 0, sum = 0, best_ours = 1e300, best_plain = 1e300, best_setup = 0;
    const double k = [&] {
        auto op = std::make_shared<PlateOperator>(fig7_plate(), Grid{job.n, job.n, side_m / job.n});
        return 0.95 * op->max_time_step();
    }();
    for (auto _ : state) {
        const double ours = run_ours(job, setup, sum);
        benchmark::DoNotOptimize(sum);
        const double plain = run_plain(job, k, sum);
        benchmark::DoNotOptimize(sum);
        if (ours < best_ours) {
            best_ours = ours;
            best_setup = setup;
        }
        best_plain = std::min(best_plain, plain);
    }
    const double cells = double(job.n - 1) * double(job.n - 1) * double(job.steps);
    state.counters["x_plain"] = best_plain / best_ours;
    state.counters["ours_Gcell/s"] = cells / best_ours * 1e-9;
    state.counters["plain_Gcell/s"] = cells / best_plain * 1e-9;
    state.counters["setup_share"] = best_setup / best_ours;
    state.SetLabel(bulk_update_isa());
}

// Several sources of the Fig. 7 plate in lanes (engine/lanes.h), one thread:
// a batch of `width` lanes against as many single runs of ours, each source
// recording one receiver every step. Reports per_lane (the batch's time per
// source over a single run's), which lanes.cpp's per_lane_cost holds.
void BM_SimulateLanes(benchmark::State &state)
{
    const int n = int(state.range(0)), width = int(state.range(2));
    const std::size_t steps = std::size_t(state.range(1));
    SimulationOptions o;
    o.engine.threads = 1;
    LanesRequest rq;
    for (int l = 0; l < width; ++l)
        rq.sources.push_back({0.2 + 0.03 * l, 0.25});
    rq.force_n = {1.0 / kirchhoff_time_step(PlateOperator(fig7_plate(), Grid{n, n, side_m / n}), o)};
    rq.receivers.push_back({0.45, 0.4});
    rq.samples = steps;
    rq.width = width;
    const Job job{n, steps, 1};
    double best_lanes = 1e300, best_single = 1e300, setup = 0, sum = 0;
    for (auto _ : state) {
        const auto t0 = std::chrono::steady_clock::now(); // from the operator's construction, as run_ours
        auto op = std::make_shared<PlateOperator>(fig7_plate(), Grid{n, n, side_m / n});
        const std::vector<LaneRecord> rec = simulate_lanes(op, o, rq);
        const double lanes = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        benchmark::DoNotOptimize(rec.back().traces[0].back());
        best_lanes = std::min(best_lanes, lanes);
        best_single = std::min(best_single, run_ours(job, setup, sum));
        benchmark::DoNotOptimize(sum);
    }
    const double cells = double(n - 1) * double(n - 1) * double(steps) * width;
    state.counters["per_lane"] = best_lanes / width / best_single;
    state.counters["lanes_Gcell/s"] = cells / best_lanes * 1e-9;
    state.SetLabel(bulk_update_isa());
}

// The placement's site recordings (pipeline/placement/site_recording.h: a
// band-limited impulse, the field copied every M-th step, the sites read off
// the copies) of 4 emitters in lanes on one thread, at `count` sites against
// one site, at Fig. 7's search rate. Reports x_one_site: the issue's "a
// simulation that records sites within 1.2x one that does not".
void BM_RecordSites(benchmark::State &state)
{
    using calib::pipeline::Point;
    const int n = int(state.range(0)), count = int(state.range(2));
    const std::size_t steps = std::size_t(state.range(1));
    SimulationOptions o;
    o.engine.threads = 1;
    const auto op = std::make_shared<const PlateOperator>(fig7_plate(), Grid{n, n, side_m / n});
    const auto rec = calib::pipeline::site_recording_options(kirchhoff_time_step(*op, o), 2866.0);
    std::vector<Point> sources, sites;
    for (int l = 0; l < 4; ++l)
        sources.push_back({0.2 + 0.03 * l, 0.25});
    for (int i = 0; i < count; ++i) { // spread over the plate (golden-ratio sequences)
        const double a = i * 0.6180339887, b = i * 0.7548776662;
        sites.push_back({0.03 + 0.64 * (a - std::floor(a)), 0.03 + 0.64 * (b - std::floor(b))});
    }
    const std::vector<Point> one{sites.front()};
    auto run = [&](const std::vector<Point> &at) {
        const auto t0 = std::chrono::steady_clock::now();
        const auto r = calib::pipeline::record_sites_of(op, o, sources, at, steps, rec, {});
        benchmark::DoNotOptimize(r.back().traces.back().back());
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
    double best_sites = 1e300, best_one = 1e300;
    for (auto _ : state) {
        best_sites = std::min(best_sites, run(sites));
        best_one = std::min(best_one, run(one));
    }
    state.counters["x_one_site"] = best_sites / best_one;
    state.counters["decimation"] = double(rec.decimation);
    state.counters["sites_ms"] = best_sites * 1e3;
    state.counters["one_site_ms"] = best_one * 1e3;
}

} // namespace

// n, steps, sites: Fig. 7's grid, window and candidate sites; the plate.
BENCHMARK(BM_RecordSites)
    ->Args({81, 14300, 464})
    ->Args({330, 4000, 464})
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// n, steps, width.
BENCHMARK(BM_SimulateLanes)
    ->Args({81, 14300, 1})
    ->Args({81, 14300, 2})
    ->Args({81, 14300, 4})
    ->Args({81, 14300, 8})
    ->Args({330, 2000, 1})
    ->Args({330, 2000, 4})
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// n, steps, threads, double. 81: Fig. 7's grid and a calibration's simulation
// length; 330: the plate at f_max 12 kHz; 1024: a large grid, fewer steps.
BENCHMARK(BM_SimulateEndToEnd)
    ->Args({81, 14300, 1, 0})
    ->Args({330, 4000, 1, 0})
    ->Args({330, 4000, 2, 0})
    ->Args({1024, 400, 1, 0})
    ->Args({1024, 400, 2, 0})
    ->Args({81, 14300, 1, 1})
    ->Args({330, 4000, 1, 1})
    ->Args({1024, 400, 1, 1})
    ->Iterations(3)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

BENCHMARK_MAIN();
