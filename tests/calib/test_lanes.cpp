// Several sources of one plate stepped side by side in lanes (engine/lanes.h)
// against the second method at hand: one Simulation per source. Per lane the
// arithmetic is the single engine's, so the records must be equal, for every
// mix of clamped and supported edges, with and without loss, in float and
// double, whatever batch width a source lands in (lossy double to round-off).
#include "engine/lanes.h"
#include "engine/simulation.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using namespace plate_test;

namespace {

LanesRequest request(const PlateOperator &op, std::size_t sources, unsigned seed)
{
    std::mt19937 rng(seed);
    const double w = op.params().size_x_m, h = op.params().size_y_m;
    std::uniform_real_distribution<double> x(0.0, w), y(0.0, h), f(-1.0, 1.0);
    LanesRequest rq;
    for (std::size_t s = 0; s < sources; ++s)
        rq.sources.push_back({x(rng), y(rng)});
    rq.sources[0] = {0.0, 0.5 * h}; // on the edge: a fixed node, no force reaches the field
    // Forces alone and in runs, zeros between (the steps the engines block).
    for (int n = 0; n < 40; ++n)
        rq.force_n.push_back(n % 6 == 0 || n == 1 || n == 2 || n == 13 || n == 17 ? f(rng) : 0.0);
    for (int r = 0; r < 5; ++r)
        rq.receivers.push_back({x(rng), y(rng)});
    rq.lattice_stride = 3;
    rq.first_step = 7;
    rq.interval = 5;
    rq.samples = 60;
    return rq;
}

// The same request, one Simulation per source.
LaneRecord single(std::shared_ptr<const PlateOperator> op, const SimulationOptions &o, const LanesRequest &rq,
                  std::size_t s)
{
    Simulation sim(op, o);
    const std::size_t src = sim.add_source(rq.sources[s].x_m, rq.sources[s].y_m);
    sim.set_source_signal(src, rq.force_n);
    for (const auto &r : rq.receivers)
        sim.add_receiver(r.x_m, r.y_m);
    sim.record_lattice(rq.lattice_stride, rq.first_step, rq.interval);
    sim.run(rq.first_step + (rq.samples - 1) * rq.interval + 1);
    LaneRecord rec;
    rec.lattice = sim.lattice_frames();
    for (const auto &t : sim.traces()) {
        rec.traces.emplace_back();
        for (std::size_t i = 0; i < rq.samples; ++i)
            rec.traces.back().push_back(t[rq.first_step + i * rq.interval]);
    }
    return rec;
}

} // namespace

TEST(Lanes, EachLaneIsItsOwnSimulation)
{
    std::size_t compared = 0;
    for (const Edges &e : mirror_edge_combinations())
        for (bool lossy : {false, true})
            for (Precision p : {Precision::f32, Precision::f64}) {
                SCOPED_TRACE(describe(e) + (lossy ? " lossy " : " lossless ") + precision_name(p));
                auto op = make_plate(23, 19, 0.01, e, 0.3, lossy ? Loss{2.0, 3e-4} : Loss{});
                SimulationOptions o;
                o.precision = p;
                o.engine.threads = 2;
                ASSERT_TRUE(lanes_apply(*op, o));
                // 11 sources over 2 threads: batches of several widths (lane_batches).
                const LanesRequest rq = request(*op, 11, 7u + unsigned(compared));
                const std::vector<LaneRecord> lanes = simulate_lanes(op, o, rq);
                ASSERT_EQ(lanes.size(), rq.sources.size());
                // The largest difference, against the largest value of the records.
                double largest = 0, diff = 0;
                for (std::size_t s = 0; s < rq.sources.size(); ++s) {
                    const LaneRecord one = single(op, o, rq, s);
                    ASSERT_EQ(lanes[s].lattice.size(), one.lattice.size());
                    for (std::size_t i = 0; i < one.lattice.size(); ++i) {
                        diff = std::max(diff, double(std::abs(lanes[s].lattice[i] - one.lattice[i])));
                        largest = std::max(largest, double(std::abs(one.lattice[i])));
                    }
                    ASSERT_EQ(lanes[s].traces.size(), one.traces.size());
                    for (std::size_t r = 0; r < one.traces.size(); ++r)
                        for (std::size_t i = 0; i < rq.samples; ++i) {
                            diff = std::max(diff, std::abs(lanes[s].traces[r][i] - one.traces[r][i]));
                            largest = std::max(largest, std::abs(one.traces[r][i]));
                        }
                }
                // Round-off only, in lossy double: up to 2e-15 of the largest
                // value (measured; 7e-16 since the bulk kernels fuse their
                // multiply-adds explicitly, so what remains is outside them).
                // Float and lossless double: the same bits.
                if (p == Precision::f64 && lossy)
                    EXPECT_LE(diff, 1e-13 * largest);
                else
                    EXPECT_EQ(diff, 0.0) << "largest value " << largest;
                EXPECT_GT(largest, 0.0); // the sources moved the plate
                for (const auto &t : lanes[0].traces)
                    for (double v : t)
                        EXPECT_EQ(v, 0.0); // the edge source moved nothing in its lane
                compared++;
            }
    EXPECT_EQ(compared, 64u);
}

TEST(Lanes, BatchesCoverEverySourceOnce)
{
    for (int threads : {1, 2, 3, 8})
        for (std::size_t count = 0; count <= 40; ++count) {
            const std::vector<LaneBatch> b = lane_batches(count, threads);
            std::size_t lanes = 0;
            for (std::size_t i = 0; i < b.size(); ++i) {
                EXPECT_TRUE(b[i].width == 1 || b[i].width == 2 || b[i].width == 4 || b[i].width == 8);
                EXPECT_GE(b[i].lanes, 1);
                EXPECT_LE(b[i].lanes, b[i].width);
                if (i > 0) {
                    EXPECT_GE(b[i - 1].width, b[i].width); // widest first
                }
                lanes += std::size_t(b[i].lanes);
            }
            EXPECT_EQ(lanes, count) << count << " sources, " << threads << " threads";
        }
    // Eight sources on two threads: one batch of four each, not eight single runs.
    const std::vector<LaneBatch> eight = lane_batches(8, 2);
    ASSERT_EQ(eight.size(), 2u);
    EXPECT_EQ(eight[0].width, 4);
    EXPECT_EQ(eight[1].width, 4);
}

TEST(Lanes, ADivergingLaneIsNamedAndAForceOutOfRangeRefused)
{
    auto op = make_plate(23, 19, 0.01, {}, 0.3);
    SimulationOptions o;
    o.engine.skip_stability_check = true;
    o.time_step_s = 1.02 * op->max_time_step(); // unstable: a moved field grows without bound
    LanesRequest rq = request(*op, 3, 3);
    rq.sources[2] = rq.sources[0]; // on the edge: its lane stays zero
    rq.samples = 20000;
    try {
        (void)simulate_lanes(op, o, rq);
        FAIL() << "the unstable run was not stopped";
    } catch (const SourceFailure &e) {
        EXPECT_EQ(e.source(), 1u);
        EXPECT_NE(std::string(e.what()).find("simulation diverged: non-finite displacement"), std::string::npos)
            << e.what();
    }

    SimulationOptions stable;
    rq = request(*op, 3, 3);
    rq.force_n[5] = std::numeric_limits<double>::quiet_NaN();
    try {
        (void)simulate_lanes(op, stable, rq);
        FAIL() << "a NaN force was not refused";
    } catch (const SourceFailure &e) {
        EXPECT_NE(std::string(e.what()).find("non-finite force (nan N) at step 5"), std::string::npos) << e.what();
    }
    rq.force_n[5] = 1e39; // beyond float
    EXPECT_THROW((void)simulate_lanes(op, stable, rq), SourceFailure);
    stable.precision = Precision::f64;
    EXPECT_NO_THROW((void)simulate_lanes(op, stable, rq));

    // A point off the plate: the source named, before any batch runs.
    rq.force_n[5] = 0.0;
    rq.sources[2] = {0.5, 0.1};
    try {
        (void)simulate_lanes(op, stable, rq);
        FAIL() << "a source off the plate was not refused";
    } catch (const SourceFailure &e) {
        EXPECT_EQ(e.source(), 2u);
        EXPECT_NE(std::string(e.what()).find("outside the plate"), std::string::npos) << e.what();
    }
    rq.sources[2] = rq.sources[1];
    rq.receivers[3] = {0.1, -0.2};
    EXPECT_THROW((void)simulate_lanes(op, stable, rq), std::invalid_argument);
    rq.receivers[3] = rq.receivers[0];
    EXPECT_NO_THROW((void)simulate_lanes(op, stable, rq));

    // A free edge has no ghost mirror: refused, Simulation's to run.
    auto free_plate =
        make_plate(23, 19, 0.01, {EdgeKind::free, EdgeKind::clamped, EdgeKind::clamped, EdgeKind::clamped});
    EXPECT_FALSE(lanes_apply(*free_plate, stable));
    EXPECT_THROW((void)simulate_lanes(free_plate, stable, rq), std::invalid_argument);
}
