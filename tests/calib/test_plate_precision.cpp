// float32 against float64 (the reference): the impulse response of a lossy
// plate agrees to ~1e-4, which is what makes float the default. With the
// update in increment form (d+ = g d - mu2 L(L(u)), u+ = u + d+) a constant
// field is exactly static in float; the folded form (2 - 20 mu^2) c + ...
// gave ~1 % here. The threaded bulk gives the same bits as one thread.
#include "engine/simulation.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace plate_test;

namespace {

std::vector<double> impulse_response(std::shared_ptr<const PlateOperator> op, Precision p, std::size_t steps)
{
    SimulationOptions opt;
    opt.precision = p;
    opt.courant = 0.95;
    Simulation sim(op, opt);
    sim.add_source(0.061, 0.047);
    sim.add_receiver(0.143, 0.101);
    sim.set_source_impulse(0);
    sim.run(steps);
    return sim.traces()[0];
}

} // namespace

TEST(PlatePrecision, FloatMatchesDoubleOnALossyPlate)
{
    // 2 mm acrylic, 0.2 x 0.15 m, loss T60 0.15 s at 300 Hz and 0.08 s at
    // 2 kHz, h = 5.6 mm (k ~ 6 us): the low modes turn by ~1e-3 rad per step,
    // where rounding matters most.
    PlateParams p;
    p.size_x_m = 0.2;
    p.size_y_m = 0.15;
    p.thickness_m = 0.002;
    p.material = *calib::physics::find_material("acrylic");
    p.edges = {EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported, EdgeKind::free};
    p.loss = loss_from_t60(p.material.kappa(p.thickness_m), 300, 0.15, 2000, 0.08);
    auto op = std::make_shared<PlateOperator>(p, Grid{36, 27, 0.2 / 36});
    const std::size_t steps = scaled(20000);
    const auto d = impulse_response(op, Precision::f64, steps);
    const auto f = impulse_response(op, Precision::f32, steps);
    double num = 0, den = 0;
    for (std::size_t n = 0; n < d.size(); ++n) {
        num += (f[n] - d[n]) * (f[n] - d[n]);
        den += d[n] * d[n];
    }
    ASSERT_GT(den, 0);
    EXPECT_LT(std::sqrt(num / den), 1e-3);
}

TEST(PlatePrecision, ConstantFieldOfAFreePlateStaysExactlyConstantInFloat)
{
    // A rigid translation of a free plate at rest feels no force: with the
    // difference form of the bulk and edge rows this holds bit-exactly in
    // float, with and without loss.
    for (const Loss loss : {Loss{}, Loss{5.0, 1e-3}}) {
        auto op = make_plate(20, 16, 0.01, Edges::all(EdgeKind::free), 0.3, loss);
        PlateEngine<float> eng(op, 0.95 * op->max_time_step());
        std::vector<double> one(op->grid().node_count(), 1e-3);
        eng.set_state(one, one);
        for (int n = 0; n < 1000; ++n)
            eng.step();
        for (double v : eng.displacement())
            ASSERT_EQ(v, double(1e-3f));
    }
}

namespace {

// 120 steps of a random state on a 40 x 30 plate (two free edges, loss or
// not), the bulk split over `threads` (every interior counts as large).
template <typename T>
std::vector<double> stepped(std::shared_ptr<const PlateOperator> op, int threads)
{
    EngineOptions o;
    o.threads = threads;
    o.parallel_min_cells = 1;
    PlateEngine<T> eng(op, 0.95 * op->max_time_step(), o);
    eng.set_state(random_field(*op, 8), random_field(*op, 9));
    for (int n = 0; n < 120; ++n)
        eng.step();
    return eng.displacement();
}

} // namespace

TEST(PlatePrecision, ThreadedBulkGivesTheBitsOfOneThread)
{
    // The bulk updates u in place: each block reads the Laplacian rows next
    // to it before its neighbour overwrites them (a prologue, then a barrier).
    // A race or a stale row would change bits; a split of 2, 3 or 7 blocks
    // must not. Inside an outer parallel region (the pipeline runs several
    // simulations at once) each engine must run on its own.
    const Edges e{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    for (Loss loss : {Loss{}, Loss{2.0, 1e-4}}) {
        auto op = make_plate(40, 30, 0.01, e, 0.3, loss);
        const auto one = stepped<float>(op, 1);
        for (int t : {2, 3, 7})
            EXPECT_EQ(stepped<float>(op, t), one) << t << " threads, sigma1 " << loss.sigma1;
        EXPECT_EQ(stepped<double>(op, 2), stepped<double>(op, 1));
        std::vector<std::vector<double>> nested(2);
#pragma omp parallel for num_threads(2)
        for (int r = 0; r < 2; ++r)
            nested[std::size_t(r)] = stepped<float>(op, r + 1);
        EXPECT_EQ(nested[0], one);
        EXPECT_EQ(nested[1], one);
    }
}
