// What each effect costs: one full step of the plate engine (bulk + edge rows
// + hooks) with and without the effect, on the same grid, in the same run.
// Every benchmark reports `x_off`: its time per step over the time per step of
// the same engine without the effect, both timed in alternating rounds in the
// same process after the benchmark loop, fastest round of each (the machine
// is shared: load that comes and goes hits both).
//
//   build/h-fx-bench/bench/bench_effects --benchmark_min_time=0.3
//
// - loss: the lossy kernel variant against the lossless one (compiled variants);
// - finger, exciter: one PointExtension hook on 4 nodes after the update;
// - thick_plate: the Mindlin engine (3 fields, staggered, sparse rows) against
//   the Kirchhoff engine (double both; also `x_off_per_second`, which counts
//   the Mindlin engine's own, different time step).
// "Off" is the plain engine: an effect the scene does not name is not
// instantiated at all, so it has nothing to cost.
#include "engine/effects/exciter.h"
#include "engine/effects/finger.h"
#include "engine/mindlin/mindlin_engine.h"
#include "engine/plate_engine.h"

#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <random>

using namespace calib::engine;
using namespace calib::engine::effects;
using namespace calib::engine::mindlin;

namespace {

std::shared_ptr<PlateOperator> plate(int n, Loss loss = {})
{
    PlateParams p;
    const double h = 0.002;
    p.size_x_m = n * h;
    p.size_y_m = n * h;
    p.thickness_m = 0.002;
    p.material = calib::physics::material_from_elastic(2500, 70e9, 0.22, "glass");
    p.edges = Edges::all(EdgeKind::clamped);
    p.loss = loss;
    return std::make_shared<PlateOperator>(p, Grid{n, n, h});
}

template <typename T>
std::unique_ptr<PlateEngine<T>> engine(std::shared_ptr<PlateOperator> op)
{
    EngineOptions o;
    o.threads = 1;
    auto e = std::make_unique<PlateEngine<T>>(op, 0.9 * op->max_time_step(), o);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-1e-6, 1e-6);
    std::vector<double> a(op->grid().node_count()), b(a.size());
    for (std::size_t i = 0; i < a.size(); ++i) {
        a[i] = u(rng);
        b[i] = u(rng);
    }
    e->set_state(a, b);
    return e;
}

template <typename Step>
double seconds_per_step(Step &&step, std::size_t steps)
{
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < steps; ++i)
        step();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / double(steps);
}

// The machine is shared: on and off are timed in alternating short rounds and
// the fastest round of each is kept, so load that comes and goes hits both.
template <typename On, typename Off>
double min_ratio(On &&on, Off &&off)
{
    std::size_t chunk = 16;
    while (seconds_per_step(on, chunk) * double(chunk) < 2e-3 && chunk < (1u << 20))
        chunk *= 2;
    double best_on = 1e300, best_off = 1e300;
    for (int round = 0; round < 15; ++round) {
        best_on = std::min(best_on, seconds_per_step(on, chunk));
        best_off = std::min(best_off, seconds_per_step(off, chunk));
    }
    return best_on / best_off;
}

template <typename T, typename On>
void report(benchmark::State &state, On &&on, PlateEngine<T> &off, int n)
{
    state.counters["x_off"] = min_ratio(on, [&] { off.step(); });
    state.counters["cells"] = double(n) * n;
}

template <typename T>
void BM_Loss(benchmark::State &state)
{
    const int n = int(state.range(0));
    auto on = engine<T>(plate(n, Loss{2.0, 1e-3}));
    auto off = engine<T>(plate(n));
    for (auto _ : state)
        on->step();
    report(
        state, [&] { on->step(); }, *off, n);
}

template <typename T>
void BM_Finger(benchmark::State &state)
{
    const int n = int(state.range(0));
    auto op = plate(n);
    auto on = engine<T>(op);
    on->add_extension(
        std::make_unique<FingerExtension>(*on, FingerSpec{0.005, 1000, 1, 0.41 * n * 0.002, 0.37 * n * 0.002}));
    auto off = engine<T>(op);
    for (auto _ : state)
        on->step();
    report(
        state, [&] { on->step(); }, *off, n);
}

template <typename T>
void BM_Exciter(benchmark::State &state)
{
    const int n = int(state.range(0));
    auto op = plate(n);
    auto on = engine<T>(op);
    ExciterSpec e{0.03, 1.07e5, 28, 3.0, true, 20};
    auto ext = std::make_unique<ExciterExtension>(*on, 0.23 * n * 0.002, 0.61 * n * 0.002, e);
    ext->set_drive(std::vector<double>(1u << 20, 0.1));
    on->add_extension(std::move(ext));
    auto off = engine<T>(op);
    for (auto _ : state)
        on->step();
    report(
        state, [&] { on->step(); }, *off, n);
}

void BM_ThickPlate(benchmark::State &state)
{
    const int n = int(state.range(0));
    PlateParams p = plate(n)->params();
    p.thickness_m = 0.008; // where the effect matters
    p.edges = Edges::all(EdgeKind::simply_supported);
    auto kop = std::make_shared<PlateOperator>(p, Grid{n, n, 0.002});
    auto mop = std::make_shared<MindlinOperator>(p, Grid{n, n, 0.002});
    MindlinEngine on(mop, 0.9 * mop->max_time_step());
    Eigen::VectorXd s = Eigen::VectorXd::Random(Eigen::Index(mop->unknown_count())) * 1e-6;
    on.set_state(s, s);
    auto off = engine<double>(kop);
    for (auto _ : state)
        on.step();
    report(
        state, [&] { on.step(); }, *off, n);
    // Per simulated second: steps scale as 1 / k.
    state.counters["x_off_per_second"] = state.counters["x_off"] * (off->time_step() / on.time_step());
}

} // namespace

BENCHMARK(BM_Loss<float>)->Arg(128)->Arg(512)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Loss<double>)->Arg(128)->Arg(512)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Finger<float>)->Arg(128)->Arg(512)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_Exciter<float>)->Arg(128)->Arg(512)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_ThickPlate)->Arg(128)->Arg(256)->Unit(benchmark::kMicrosecond);

BENCHMARK_MAIN();
