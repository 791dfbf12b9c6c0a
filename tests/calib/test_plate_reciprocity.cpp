// Reciprocity: the response at B to a force at A equals the response at A to
// the same force at B, to round-off, for off-grid points (bilinear spreading
// and interpolation), mixed edges with a free corner, with and without loss.
#include "engine/simulation.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace plate_test;

namespace {

std::vector<double> response(std::shared_ptr<const PlateOperator> op, double k, double ax, double ay, double bx,
                             double by, std::size_t steps)
{
    SimulationOptions opt;
    opt.precision = Precision::f64;
    opt.time_step_s = k;
    Simulation sim(op, opt);
    const std::size_t s = sim.add_source(ax, ay);
    sim.add_receiver(bx, by);
    // A short smooth force pulse (Hann, 40 steps), not just an impulse.
    std::vector<double> f(40);
    for (std::size_t n = 0; n < f.size(); ++n)
        f[n] = std::pow(std::sin(3.14159265358979 * double(n) / 39.0), 2);
    sim.set_source_signal(s, f);
    sim.run(steps);
    return sim.traces()[0];
}

} // namespace

TEST(PlateReciprocity, SwappingSourceAndReceiverGivesTheSameTrace)
{
    const Edges edges{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    for (const Loss loss : {Loss{}, Loss{3.0, 2e-4}}) {
        auto op = make_plate(30, 24, 0.01, edges, 0.3, loss);
        const double k = 0.9 * op->max_time_step();
        // A near the free corner (0, 0), B inside; neither on a node.
        const double ax = 0.0137, ay = 0.0071, bx = 0.2163, by = 0.1549;
        const auto ab = response(op, k, ax, ay, bx, by, 3000);
        const auto ba = response(op, k, bx, by, ax, ay, 3000);
        double peak = 0, diff = 0;
        for (std::size_t n = 0; n < ab.size(); ++n) {
            peak = std::max(peak, std::abs(ab[n]));
            diff = std::max(diff, std::abs(ab[n] - ba[n]));
        }
        ASSERT_GT(peak, 0);
        EXPECT_LT(diff, 1e-11 * peak) << "loss sigma0 " << loss.sigma0;
        // The check is not vacuous: moving B by a fraction of a cell changes it.
        const auto ac = response(op, k, ax, ay, bx + 0.003, by, 3000);
        double moved = 0;
        for (std::size_t n = 0; n < ab.size(); ++n)
            moved = std::max(moved, std::abs(ab[n] - ac[n]));
        EXPECT_GT(moved, 1e-3 * peak);
    }
}

TEST(PlateReciprocity, SourceSpreadingIsContinuousAcrossNodes)
{
    // Bilinear weights: a source moving across a node changes the response
    // continuously (no jump as it passes the node).
    auto op = make_plate(20, 20, 0.01, Edges::all(EdgeKind::clamped));
    const double k = 0.9 * op->max_time_step();
    const auto left = response(op, k, 0.1 - 1e-9, 0.1, 0.15, 0.13, 400);
    const auto right = response(op, k, 0.1 + 1e-9, 0.1, 0.15, 0.13, 400);
    double peak = 0, diff = 0;
    for (std::size_t n = 0; n < left.size(); ++n) {
        peak = std::max(peak, std::abs(left[n]));
        diff = std::max(diff, std::abs(left[n] - right[n]));
    }
    EXPECT_LT(diff, 1e-6 * peak);
}
