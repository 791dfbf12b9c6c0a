// A team of threads on one plate (plate_kernels.h, bulk_update_block): the
// rows cut at seams, even or moved towards the threads' speeds
// (balance_seams), give the bits of one thread; the whole-field scan inside
// a run of blocks ends it where single steps' scans would.
#include "engine/plate_engine.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

using namespace plate_test;
using namespace calib::engine;

namespace {

constexpr std::ptrdiff_t stride = 16; // columns -2 .. 13 of a 9-interval-wide plate

// A field of u and d for bulk_update_block, rows -3 .. ny + 2, and the
// scratch of a team.
struct Fields {
    std::vector<float> u, d, scratch;
    Fields(int ny, int threads)
        : u(std::size_t((ny + 6) * stride)), d(u.size()),
          scratch(std::size_t((threads * bulk_block_scratch_rows + 1) * stride))
    {}
    float *u0() { return u.data() + 3 * stride + 2; }
    float *d0() { return d.data() + 3 * stride + 2; }
    float *scratch0() { return scratch.data() + 2; }
};

// A team of two threads on any plate, however small.
EngineOptions two_threads()
{
    EngineOptions team;
    team.threads = 2;
    team.parallel_min_cells = 0;
    return team;
}

bool same_bits(const std::vector<float> &a, const std::vector<float> &b)
{
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

} // namespace

// Any cut of the rows (each thread at least block_min_rows_per_thread)
// gives the bits of one thread, in u and d, and each thread's busy time is
// measured; a cut that leaves a thread too few rows, or does not run from
// the first row to the last, is refused.
TEST(PlateTeam, AnyCutOfTheRowsGivesTheBitsOfOneThread)
{
    constexpr int nx = 9, steps = bulk_max_block_steps, blocks = 3, fewest = block_min_rows_per_thread;
    const int ny = 3 * fewest + 20;
    const auto op = make_plate(nx, ny, 0.01, Edges::all(EdgeKind::simply_supported), 0.3, Loss{2.0, 5e-4});
    const BulkCoefficients<float> c{0.99f, 0.01f, 0.002f, ghost_mirrors_of<float>(*op)};
    auto run = [&](int threads, const BlockTeam *team) {
        Fields f(ny, threads);
        for (int j = 1; j < ny; ++j)
            for (int i = 1; i < nx; ++i) {
                f.u0()[j * stride + i] = float(std::sin(0.3 * i) * std::sin(0.2 * j));
                f.d0()[j * stride + i] = float(1e-3 * std::cos(0.7 * i + 0.1 * j));
            }
        bulk_update_block<float, true>(f.u0(), f.d0(), stride, 1, nx, 1, ny, c, steps, threads, f.scratch0(), nullptr,
                                       nullptr, nullptr, blocks, nullptr, team);
        std::vector<float> both = f.u;
        both.insert(both.end(), f.d.begin(), f.d.end());
        return both;
    };
    const std::vector<float> one = run(1, nullptr);
    const std::vector<std::vector<int>> cuts = {{1, 1 + fewest, ny},      {1, ny - fewest, ny},
                                                {1, ny / 2, ny},          {1, 1 + fewest, 1 + 2 * fewest, ny},
                                                {1, 40, ny - fewest, ny}, {1, 1 + fewest, ny - fewest, ny}};
    for (const auto &cut : cuts) {
        const int threads = int(cut.size()) - 1;
        std::vector<double> busy(std::size_t(threads), -1.0);
        const BlockTeam team{cut.data(), busy.data()};
        EXPECT_TRUE(same_bits(run(threads, &team), one)) << "seam " << cut[1];
        for (double b : busy)
            EXPECT_GT(b, 0.0) << "seam " << cut[1];
    }
    const std::vector<std::vector<int>> refused = {
        {1, fewest, ny}, {1, ny - fewest + 1, ny}, {2, 50, ny}, {1, 50, ny - 1}, {1, 40, 40 + fewest - 1, ny}};
    for (const auto &cut : refused) {
        const BlockTeam team{cut.data(), nullptr};
        EXPECT_THROW(run(int(cut.size()) - 1, &team), std::invalid_argument) << "seam " << cut[1];
    }
}

// balance_seams by hand: rows in proportion to speed (rows / busy time),
// half-way from where they are, rounded on the running sum, each thread
// keeping block_min_rows_per_thread rows.
TEST(PlateTeam, SeamsMoveHalfWayTowardsTheThreadsSpeeds)
{
    auto balanced = [](std::vector<int> seam, std::vector<double> busy) {
        balance_seams(seam.data(), busy.data(), int(busy.size()));
        return seam;
    };
    // Equal speeds: 164 and 165 rows stay.
    EXPECT_EQ(balanced({1, 165, 330}, {1.0, 165.0 / 164}), (std::vector<int>{1, 165, 330}));
    // Thread 1 a third slower: speeds 164 and 122.22 rows per unit, thread
    // 0's share 329 x 164 / 286.22 = 188.51, half-way from 164: 176.25 rows.
    EXPECT_EQ(balanced({1, 165, 330}, {1.0, 1.35}), (std::vector<int>{1, 177, 330}));
    EXPECT_EQ(balanced({1, 165, 330}, {1.35, 1.0}), (std::vector<int>{1, 153, 330}));
    // Three threads, the middle one at half speed: shares 132, 66, 132 of
    // 330 rows; half-way from 110 each: 121, 88, 121.
    EXPECT_EQ(balanced({1, 111, 221, 331}, {1.0, 2.0, 1.0}), (std::vector<int>{1, 122, 210, 331}));
    // Half-way would leave thread 1 with 28 rows (302 .. 330): it keeps 32.
    EXPECT_EQ(balanced({1, 280, 330}, {1.0, 10.0}), (std::vector<int>{1, 330 - block_min_rows_per_thread, 330}));
    EXPECT_EQ(balanced({1, 50, 330}, {10.0, 1.0}), (std::vector<int>{1, 1 + block_min_rows_per_thread, 330}));
    // No time measured, or too few rows for the team to keep 32 each: unchanged.
    EXPECT_EQ(balanced({1, 165, 330}, {0.0, 1.0}), (std::vector<int>{1, 165, 330}));
    EXPECT_EQ(balanced({1, 30, 60}, {1.0, 3.0}), (std::vector<int>{1, 30, 60}));
}

// The whole-field scan on a team (each thread its own rows, as the sweep cuts
// them): a non-finite node in any row is found, and named first in row order.
TEST(PlateTeam, AScanOnATeamFindsANonFiniteNodeInAnyRow)
{
    auto op = make_plate(9, 71, 0.01, Edges::all(EdgeKind::clamped));
    PlateEngine<float> eng(op, 0.9 * op->max_time_step(), two_threads());
    ASSERT_TRUE(eng.threaded());
    const std::vector<double> zero(op->grid().node_count(), 0.0);
    eng.set_state(zero, zero);
    EXPECT_EQ(eng.non_finite_report(), "");
    auto report_with = [&](std::vector<std::pair<int, int>> nodes) {
        std::vector<double> field = zero;
        for (auto [i, j] : nodes)
            field[std::size_t(j) * 10 + std::size_t(i)] = std::nan("");
        eng.set_state(field, zero);
        return eng.non_finite_report();
    };
    for (int j = 1; j < 71; ++j) { // every row of unknowns
        const std::string report = report_with({{4, j}});
        EXPECT_NE(report.find("first at node (i, j) = (4, " + std::to_string(j) + ")"), std::string::npos)
            << "row " << j << ": " << report;
    }
    const std::string two = report_with({{2, 70}, {4, 3}});
    EXPECT_NE(two.find("first at node (i, j) = (4, 3)"), std::string::npos) << two;
    EXPECT_NE(two.find("2 non-finite nodes"), std::string::npos) << two;
}

// The scan inside a run of blocks (BlockScan): after each block it marks,
// every thread tests the nodes it updates; the first scan that sees a
// non-finite node ends the run after its block on every thread, and the
// field is then the field after that many blocks. A run whose scans find nothing runs every block, to the same bits
// as a run without scans.
TEST(PlateTeam, AScanInARunEndsItAfterTheFirstBlockWhoseScanSeesANonFiniteNode)
{
    using namespace calib::engine;
    constexpr int nx = 9, steps = bulk_max_block_steps, blocks = 5;
    const std::ptrdiff_t s = 16; // columns -2 .. 13
    const std::vector<std::uint8_t> after = {0, 1, 0, 1, 1};
    for (int threads : {1, 2, 3}) {
        const int ny = threads * block_min_rows_per_thread + 5;
        const auto op = make_plate(nx, ny, 0.01, Edges::all(EdgeKind::clamped), 0.3, Loss{2.0, 5e-4});
        const BulkCoefficients<float> c{0.99f, 0.01f, 0.002f, ghost_mirrors_of<float>(*op)};
        // Runs `count` blocks from a smooth field with `nan` at node (i, j)
        // (none if i < 0); returns the field of u after them, row by row.
        auto run = [&](int i, int j, BlockScan *scan, int count) {
            std::vector<float> u(std::size_t((ny + 6) * s)), d(u.size()),
                scratch(std::size_t((threads * bulk_block_scratch_rows + 1) * s));
            float *const u0 = u.data() + 3 * s + 2;
            for (int jj = 1; jj < ny; ++jj)
                for (int ii = 1; ii < nx; ++ii)
                    u0[jj * s + ii] = float(std::sin(0.3 * ii) * std::sin(0.2 * jj));
            if (i >= 0)
                u0[j * s + i] = std::nanf("");
            bulk_update_block<float, true>(u0, d.data() + 3 * s + 2, s, 1, nx, 1, ny, c, steps, threads,
                                           scratch.data() + 2, nullptr, nullptr, nullptr, count, scan);
            std::vector<float> field;
            for (int jj = 0; jj <= ny; ++jj)
                field.insert(field.end(), u0 + jj * s, u0 + jj * s + nx + 1);
            return field;
        };
        auto same_bits = [](const std::vector<float> &a, const std::vector<float> &b) {
            return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
        };
        SCOPED_TRACE(std::to_string(threads) + " threads");
        BlockScan clean{after.data()};
        EXPECT_TRUE(same_bits(run(-1, 0, &clean, blocks), run(-1, 0, nullptr, blocks)));
        EXPECT_EQ(clean.blocks_done, blocks);
        EXPECT_FALSE(clean.found);
        // A non-finite node in each thread's rows and beside each seam, in
        // the corners and on the boundary (which the scan leaves: the rows
        // next to it read it).
        std::vector<std::pair<int, int>> nodes = {{1, 1},      {nx - 1, ny - 1}, {0, 0}, {nx, ny},
                                                  {0, ny / 2}, {nx, 3},          {4, 0}, {5, ny}};
        for (int t = 0; t < threads; ++t) {
            const int seam = block_seam(1, ny, threads, t);
            nodes.insert(nodes.end(), {{3, seam}, {6, std::max(1, seam - 1)}, {2, seam + 7}});
        }
        for (auto [i, j] : nodes) {
            BlockScan scan{after.data()};
            const std::vector<float> stopped = run(i, j, &scan, blocks);
            EXPECT_EQ(scan.blocks_done, 2) << "node (" << i << ", " << j << ")";
            EXPECT_TRUE(scan.found) << "node (" << i << ", " << j << ")";
            EXPECT_TRUE(same_bits(stopped, run(i, j, nullptr, 2))) << "node (" << i << ", " << j << ")";
        }
    }
}

// The engine keeps what its last run's scan found (non_finite_report() is
// then free) only while nothing else touched the field: a displacement added
// or a state set after it is scanned again.
TEST(PlateTeam, AScanInARunIsForgottenOnceTheFieldChanges)
{
    auto op = make_plate(9, 71, 0.01, Edges::all(EdgeKind::clamped));
    PlateEngine<float> eng(op, 0.9 * op->max_time_step(), two_threads());
    ASSERT_TRUE(eng.can_block());
    const std::vector<std::uint8_t> after = {1, 1};
    const std::vector<double> field = random_field(*op, 3);
    eng.set_state(field, field);
    ASSERT_EQ(eng.step_block(calib::engine::bulk_max_block_steps, nullptr, 2, after.data()), 2);
    EXPECT_EQ(eng.non_finite_report(), "");
    eng.add_displacement(5 * eng.stride() + 4, std::nanf(""));
    EXPECT_NE(eng.non_finite_report().find("first at node (i, j) = (4, 5)"), std::string::npos);
    ASSERT_EQ(eng.step_block(calib::engine::bulk_max_block_steps, nullptr, 2, after.data()), 1);
    EXPECT_NE(eng.non_finite_report(), "");
    std::vector<double> bad = field;
    bad[op->grid().node(3, 60)] = std::nan("");
    eng.set_state(field, field);
    ASSERT_EQ(eng.step_block(calib::engine::bulk_max_block_steps, nullptr, 2, after.data()), 2);
    eng.set_state(bad, field);
    EXPECT_NE(eng.non_finite_report().find("first at node (i, j) = (3, 60)"), std::string::npos);
}
