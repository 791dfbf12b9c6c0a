// Clamped and simply supported edges run without an edge band: the engine
// sets ghost nodes mirrored across each edge and lets the bulk kernel update
// every unknown. That is only right if the assembled operator's rows next to
// such an edge are the mirrored 13-point stencil (and the loss operator's the
// 5-point Laplacian with the boundary at zero): checked here coefficient by
// coefficient against stencils built by hand, and the two engines (ghosts,
// and the sparse edge rows forced) checked against each other over a run,
// for every mix of the two edge kinds, with loss, in double and float.
#include "engine/plate_engine.h"
#include "engine/simulation.h"
#include "test_plate_util.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

using namespace plate_test;

namespace {

std::string name_of(const Edges &e)
{
    auto n = [](EdgeKind k) { return k == EdgeKind::clamped ? "C" : k == EdgeKind::free ? "F" : "S"; };
    return std::string(n(e.left)) + n(e.right) + n(e.bottom) + n(e.top);
}

} // namespace

TEST(EngineMirrorEdges, RowsNextToTheEdgeAreTheMirroredStencil)
{
    const int nx = 11, ny = 9;
    const double h = 0.01;
    for (const Edges &e : mirror_edge_combinations()) {
        auto op = make_plate(nx, ny, h, e, 0.3, Loss{1.0, 2e-4});
        const double kscale = op->kappa() * op->kappa() / std::pow(h, 4), gscale = 1 / (h * h);
        auto unknown = [&](int i, int j) { return op->unknown_of()[op->grid().node(i, j)]; };
        auto sign = [](EdgeKind k) { return k == EdgeKind::clamped ? 1.0 : -1.0; };
        double worst_k = 0, worst_g = 0;
        for (int j = 1; j < ny; ++j)
            for (int i = 1; i < nx; ++i) {
                // The hand-built rows: a ghost beyond an edge is the mirror of the
                // node inside, times the edge's sign; boundary nodes are zero.
                std::map<std::pair<int, int>, double> k_row, g_row;
                auto add = [&](std::map<std::pair<int, int>, double> &row, int a, int b, double c) {
                    if (a < 0)
                        a = -a, c *= sign(e.left);
                    if (a > nx)
                        a = 2 * nx - a, c *= sign(e.right);
                    if (b < 0)
                        b = -b, c *= sign(e.bottom);
                    if (b > ny)
                        b = 2 * ny - b, c *= sign(e.top);
                    if (a > 0 && a < nx && b > 0 && b < ny)
                        row[{a, b}] += c;
                };
                add(k_row, i, j, 20);
                add(g_row, i, j, 4);
                for (auto [a, b] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
                    add(k_row, i + a, j + b, -8);
                    add(k_row, i + 2 * a, j + 2 * b, 1);
                    add(g_row, i + a, j + b, -1);
                }
                for (auto [a, b] : {std::pair{1, 1}, {-1, 1}, {1, -1}, {-1, -1}})
                    add(k_row, i + a, j + b, 2);
                const auto u = unknown(i, j);
                const double m = op->mass()[u];
                auto compare = [&](const PlateOperator::SparseMatrix &a,
                                   const std::map<std::pair<int, int>, double> &want, double scale, double &worst) {
                    double got_sum = 0, want_sum = 0;
                    for (PlateOperator::SparseMatrix::InnerIterator it(a, u); it; ++it)
                        got_sum += std::abs(it.value()) / m / scale;
                    for (const auto &[ij, c] : want) {
                        worst = std::max(worst, std::abs(a.coeff(u, unknown(ij.first, ij.second)) / m / scale - c));
                        want_sum += std::abs(c);
                    }
                    worst = std::max(worst, std::abs(got_sum - want_sum)); // and nothing else in the row
                };
                compare(op->stiffness(), k_row, kscale, worst_k);
                compare(op->dirichlet(), g_row, gscale, worst_g);
            }
        EXPECT_LT(worst_k, 1e-12) << name_of(e);
        EXPECT_LT(worst_g, 1e-12) << name_of(e);
        EXPECT_EQ(op->mass().maxCoeff(), op->mass().minCoeff()) << name_of(e);
    }
}

namespace {

// The ghost engine and the edge-band engine from the same random state: the
// largest difference of the fields after `steps`, over the largest value.
template <typename T>
double ghost_against_band(const Edges &e, std::size_t steps, bool &mirrored)
{
    auto op = make_plate(23, 17, 0.01, e, 0.3, Loss{2.0, 5e-4});
    const double k = 0.9 * op->max_time_step();
    EngineOptions band_opt;
    band_opt.edge_band_always = true;
    PlateEngine<T> ghost(op, k), band(op, k, band_opt);
    mirrored = ghost.mirror_edges() && !band.mirror_edges();
    const auto a = random_field(*op, 5), b = random_field(*op, 6);
    ghost.set_state(a, b);
    band.set_state(a, b);
    const std::size_t src = ghost.add_source(0.071, 0.093);
    band.add_source(0.071, 0.093);
    // A second source on nodes next to the left and top edges: what it adds
    // after the sweep moves nodes the ghosts mirror (PlateEngine refreshes them).
    const std::size_t edge_src = ghost.add_source(0.013, 0.162);
    band.add_source(0.013, 0.162);
    for (std::size_t n = 0; n < steps; ++n) {
        const double f = n < 40 ? std::sin(0.3 * double(n)) : 0.0;
        ghost.set_source_force(src, f);
        band.set_source_force(src, f);
        const double fe = n >= 100 && n < 130 ? std::cos(0.2 * double(n)) : 0.0;
        ghost.set_source_force(edge_src, fe);
        band.set_source_force(edge_src, fe);
        ghost.step();
        band.step();
    }
    const auto x = ghost.displacement(), y = band.displacement();
    double diff = 0, peak = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        diff = std::max(diff, std::abs(x[i] - y[i]));
        peak = std::max(peak, std::abs(y[i]));
    }
    EXPECT_GT(peak, 0.0);
    return diff / peak;
}

} // namespace

TEST(EngineMirrorEdges, GhostsAndEdgeRowsGiveTheSameRunToRoundOff)
{
    for (const Edges &e : mirror_edge_combinations()) {
        bool mirrored = false;
        // Double: the two differ only in summation order (the band sums in double too).
        EXPECT_LT(ghost_against_band<double>(e, 2000, mirrored), 1e-11) << name_of(e);
        EXPECT_TRUE(mirrored) << name_of(e);
        // Float: the band rows sum in double, the bulk in float; 2000 steps of
        // float round-off, against a field of order one.
        EXPECT_LT(ghost_against_band<float>(e, 2000, mirrored), 1e-4) << name_of(e);
    }
}

TEST(EngineMirrorEdges, AFreeEdgeKeepsTheEdgeBand)
{
    auto free = make_plate(12, 10, 0.01, {EdgeKind::clamped, EdgeKind::free, EdgeKind::clamped, EdgeKind::clamped});
    EXPECT_FALSE(PlateEngine<double>(free, 0.9 * free->max_time_step()).mirror_edges());
    auto supported = make_plate(12, 10, 0.01, Edges::all(EdgeKind::simply_supported));
    EXPECT_TRUE(PlateEngine<double>(supported, 0.9 * supported->max_time_step()).mirror_edges());
}

TEST(EngineMirrorEdges, EnergyIsConservedWithoutLossAndFallsWithIt)
{
    for (const Edges &e : mirror_edge_combinations()) {
        for (Loss loss : {Loss{}, Loss{3.0, 1e-3}}) {
            auto op = make_plate(19, 14, 0.01, e, 0.3, loss);
            PlateEngine<double> eng(op, 0.95 * op->max_time_step());
            ASSERT_TRUE(eng.mirror_edges());
            eng.set_state(random_field(*op, 3), random_field(*op, 4));
            double before = eng.energy(), worst_rise = 0;
            const double e0 = before;
            for (int n = 0; n < 3000; ++n) {
                eng.step();
                const double now = eng.energy();
                worst_rise = std::max(worst_rise, (now - before) / e0);
                before = now;
            }
            if (!loss.active())
                EXPECT_LT(std::abs(before / e0 - 1), 1e-11) << name_of(e);
            else
                EXPECT_LT(before, 0.5 * e0) << name_of(e);
            EXPECT_LT(worst_rise, 1e-12) << name_of(e);
        }
    }
}

namespace {

// Several steps in one sweep against step() as many times from the same
// state: the same arithmetic term for term, so the same bits, in every field
// and in every receiver between the steps and after them. A source drives the
// last step of some blocks (a force in an earlier one refuses a block).
template <typename T>
void block_against_single(const Edges &e, const Loss &loss, int nx, int ny, int steps, int threads = 1, int blocks = 1)
{
    auto op = make_plate(nx, ny, 0.01, e, 0.3, loss);
    const double k = 0.9 * op->max_time_step();
    EngineOptions team;
    team.threads = threads;
    team.parallel_min_cells = 0;
    PlateEngine<T> blocked(op, k, team), single(op, k);
    ASSERT_TRUE(blocked.can_block()) << name_of(e);
    ASSERT_EQ(blocked.threaded(), threads > 1);
    const auto a = random_field(*op, 7), b = random_field(*op, 8);
    blocked.set_state(a, b);
    single.set_state(a, b);
    // Receivers on every row band, the last on the top edge's row of nodes.
    const double lx = nx * 0.01, ly = ny * 0.01;
    // With threads, one between every two rows and one on every row too
    // (the blocks' seams and the rows between them).
    std::vector<std::pair<double, double>> at = {{0.31, 0.05}, {0.52, 0.5}, {0.013, 0.97}, {0.77, 0.993}, {0.5, 1.0}};
    for (int j = 1; threads > 1 && j < ny; ++j) {
        at.emplace_back((0.1 + 0.8 * j / ny), (j + 0.5) / ny);
        at.emplace_back((0.9 - 0.8 * j / ny), double(j) / ny);
    }
    const std::size_t R = at.size();
    for (auto [x, y] : at)
        for (PlateEngine<T> *eng : {&blocked, &single})
            eng->add_receiver(x * lx, y * ly);
    const std::size_t src = blocked.add_source(0.4 * lx, 0.6 * ly);
    single.add_source(0.4 * lx, 0.6 * ly);
    std::vector<double> between(R * std::size_t(steps * blocks - 1));
    for (int n = 0; n < 600 / (steps * blocks); ++n) {
        const double f = n % 3 == 0 ? std::sin(0.7 * n) : 0.0;
        blocked.set_source_force(src, f);
        blocked.step_block(steps, between.data(), blocks);
        for (int m = 1; m < steps * blocks; ++m) {
            single.set_source_force(src, 0.0);
            single.step();
            for (std::size_t r = 0; r < R; ++r)
                ASSERT_EQ(between[std::size_t(m - 1) * R + r], single.receiver_value(r))
                    << name_of(e) << " block " << n << " level " << m << " receiver " << r;
        }
        single.set_source_force(src, f);
        single.step();
        for (std::size_t r = 0; r < R; ++r)
            ASSERT_EQ(blocked.receiver_value(r), single.receiver_value(r)) << name_of(e) << " block " << n;
    }
    EXPECT_EQ(blocked.steps_done(), single.steps_done());
    const auto x = blocked.displacement(), y = single.displacement();
    for (std::size_t i = 0; i < x.size(); ++i)
        ASSERT_EQ(x[i], y[i]) << name_of(e) << " node " << i;
    EXPECT_NE(blocked.energy(), 0.0);
    EXPECT_EQ(blocked.energy(), single.energy()) << name_of(e); // the newest increment too
}

} // namespace

TEST(EngineMirrorEdges, StepsInOneSweepAreStepsBitForBit)
{
    for (int steps = 2; steps <= calib::engine::bulk_max_block_steps; ++steps) {
        for (const Edges &e : mirror_edge_combinations())
            for (const Loss &loss : {Loss{}, Loss{2.0, 5e-4}}) {
                block_against_single<double>(e, loss, 23, 17, steps);
                block_against_single<float>(e, loss, 23, 17, steps);
            }
        // The smallest grids a block runs on: one and two rows of unknowns fewer than the lag.
        block_against_single<float>(Edges::all(EdgeKind::clamped), Loss{2.0, 5e-4}, 6, 4, steps);
        block_against_single<double>(Edges::all(EdgeKind::simply_supported), Loss{}, 5, 5, steps);
    }
}

// The same with the rows cut into blocks over a team (plate_kernels.cpp:
// overlapping trapezoids, the rows beyond each seam on copies): 2 and 3
// threads, the fewest rows a thread may take and more, receivers on every
// row and between every two (those across a seam read the copy below).
TEST(EngineMirrorEdges, StepsInOneSweepOnATeamAreStepsBitForBit)
{
    const int fewest = calib::engine::block_min_rows_per_thread;
    for (int steps = 2; steps <= calib::engine::bulk_max_block_steps; ++steps)
        for (int threads : {2, 3}) {
            const Edges e{EdgeKind::clamped, EdgeKind::simply_supported, EdgeKind::simply_supported, EdgeKind::clamped};
            block_against_single<float>(e, Loss{2.0, 5e-4}, 9, threads * fewest + 1, steps, threads);
            block_against_single<double>(e, Loss{}, 8, threads * fewest + 7, steps, threads);
            block_against_single<double>(Edges::all(EdgeKind::clamped), Loss{2.0, 5e-4}, 7, 2 * threads * fewest + 3,
                                         steps, threads);
            // Several blocks in one region: one barrier each, the copies
            // taken at the end of each trapezoid into the other set.
            for (int blocks : {2, 5}) {
                block_against_single<float>(e, Loss{2.0, 5e-4}, 9, threads * fewest + 1, steps, threads, blocks);
                block_against_single<double>(e, Loss{}, 8, threads * fewest + 7, steps, threads, blocks);
            }
        }
    for (int blocks : {2, 5}) // on one thread
        block_against_single<float>(Edges::all(EdgeKind::simply_supported), Loss{2.0, 5e-4}, 23, 17,
                                    calib::engine::bulk_max_block_steps, 1, blocks);
    // Too few rows for the team: refused, and the engine says so beforehand.
    auto op = make_plate(9, 2 * fewest - 1, 0.01, Edges::all(EdgeKind::clamped));
    EngineOptions team;
    team.threads = 2;
    team.parallel_min_cells = 0;
    PlateEngine<float> eng(op, 0.9 * op->max_time_step(), team);
    EXPECT_FALSE(eng.can_block());
    EXPECT_THROW(eng.step_block(2, nullptr), std::logic_error);
}

// The kernel's promise to its readers (plate_kernels.h): after each step but
// the last, every row is reported once, by one thread, whatever the team; a
// block reports only its own rows, not the rows beyond its seams it updates
// on its copies; given hook_rows, only the rows it marks.
namespace {
struct Reports {
    int rows = 0;
    std::vector<std::atomic<int>> count; // (level, row)
    explicit Reports(std::size_t n) : count(n) {}
};
void count_report(void *ctx, int level, int row, const calib::engine::BlockBelow &)
{
    Reports &r = *static_cast<Reports *>(ctx);
    ++r.count[std::size_t(level * r.rows + row)];
}
} // namespace

TEST(EngineMirrorEdges, ATeamReportsEachRowOfEachLevelBetweenOnce)
{
    using namespace calib::engine;
    const int nx = 9;
    const std::ptrdiff_t s = 16; // columns -2 .. 13
    for (bool marked : {false, true})
        for (int threads : {1, 2, 3})
            for (int steps = 2; steps <= bulk_max_block_steps; ++steps)
                for (int blocks : {1, 3}) {
                    const int ny = threads * block_min_rows_per_thread + 5;
                    std::vector<std::uint8_t> rows(std::size_t(ny + 1));
                    for (std::size_t j = 0; j < rows.size(); ++j)
                        rows[j] = j % 3 == 1 || j == 2; // rows 1, 2, 4, 7, ...: marked and unmarked rows in every block
                    std::vector<float> u(std::size_t((ny + 6) * s)), d(u.size()),
                        scratch(std::size_t((threads * bulk_block_scratch_rows + 1) * s));
                    const BulkCoefficients<float> c{1.0f, 0.01f, 0.0f, {}};
                    Reports r(std::size_t(steps * blocks * (ny + 1)));
                    r.rows = ny + 1;
                    bulk_update_block<float, false>(u.data() + 3 * s + 2, d.data() + 3 * s + 2, s, 1, nx, 1, ny, c,
                                                    steps, threads, scratch.data() + 2, count_report, &r,
                                                    marked ? rows.data() : nullptr, blocks);
                    for (int level = 0; level < steps * blocks; ++level)
                        for (int row = 0; row <= ny; ++row)
                            ASSERT_EQ(r.count[std::size_t(level * r.rows + row)].load(),
                                      level > 0 && row >= 1 && row < ny && (!marked || rows[std::size_t(row)]) ? 1 : 0)
                                << threads << " threads, " << blocks << " blocks of " << steps << " steps, level "
                                << level << " row " << row << (marked ? ", every third row marked" : "");
                }
}

namespace {

// A Simulation (run `steps` steps from rest: one source at (x, y) with
// `force`, receivers `at`, a lattice of `stride` from step `first` every
// `interval`) against the engine stepped one step at a time with the same
// forces: the same bits in every trace, every lattice frame and the final
// field.
void expect_as_single_steps(const Simulation &sim, const std::shared_ptr<PlateOperator> &op, Precision p, double x,
                            double y, const std::vector<double> &force,
                            const std::vector<std::pair<double, double>> &at, std::size_t steps, int stride,
                            std::size_t first, std::size_t interval)
{
    const int nx = op->grid().nx, ny = op->grid().ny;
    auto check = [&](auto &eng) {
        ASSERT_TRUE(eng.can_block());
        const std::size_t src = eng.add_source(x, y);
        for (auto [rx, ry] : at)
            eng.add_receiver(rx, ry);
        std::vector<float> frames;
        for (std::size_t n = 0; n < steps; ++n) {
            eng.set_source_force(src, n < force.size() ? force[n] : 0.0);
            eng.step();
            for (std::size_t r = 0; r < at.size(); ++r)
                ASSERT_EQ(sim.traces()[r][n], eng.receiver_value(r)) << "step " << n << " receiver " << r;
            if (n >= first && (n - first) % interval == 0)
                for (int j = 0; j <= ny; j += stride)
                    for (int i = 0; i <= nx; i += stride)
                        frames.push_back(float(eng.w_at(i, j)));
        }
        ASSERT_EQ(sim.lattice_frames().size(), frames.size());
        for (std::size_t f = 0; f < frames.size(); ++f)
            ASSERT_EQ(sim.lattice_frames()[f], frames[f]) << "lattice value " << f;
        EXPECT_EQ(sim.snapshot(), eng.displacement());
    };
    const double k = sim.time_step_s();
    if (p == Precision::f32) {
        PlateEngine<float> eng(op, k);
        check(eng);
    } else {
        PlateEngine<double> eng(op, k);
        check(eng);
    }
}

} // namespace

// A Simulation steps in blocks (bulk_update_block) wherever nothing but its
// receivers is due between steps: no force but in a block's last step, no
// lattice frame or scan after any but the last. Against the engine stepped
// one step at a time with the same forces: the same bits in every trace,
// every lattice frame and the final field, for a signal with forces alone and
// in runs, a lattice and scans at intervals prime to each other and runs cut
// anywhere.
TEST(EngineMirrorEdges, ASimulationBlocksOnlyStepsWithNothingButReceiversBetween)
{
    for (Precision p : {Precision::f32, Precision::f64}) {
        auto op = make_plate(
            21, 17, 0.01,
            Edges{EdgeKind::clamped, EdgeKind::simply_supported, EdgeKind::clamped, EdgeKind::simply_supported}, 0.3,
            Loss{2.0, 5e-4});
        SimulationOptions o;
        o.precision = p;
        o.field_check_interval = 7;
        Simulation sim(op, o);
        std::vector<double> force(90, 0.0);
        for (int n : {0, 1, 2, 6, 11, 13, 14, 15, 16, 29, 34, 35, 60, 89})
            force[std::size_t(n)] = std::cos(0.3 * n) + 0.5;
        const double x = 0.08, y = 0.1;
        sim.set_source_signal(sim.add_source(x, y), force);
        const std::vector<std::pair<double, double>> at = {{0.05, 0.02}, {0.13, 0.09}, {0.2, 0.16}};
        for (auto [rx, ry] : at)
            sim.add_receiver(rx, ry);
        sim.record_lattice(4, 5, 9);
        for (int run : {1, 3, 10, 17, 40, 29})
            sim.run(std::size_t(run));

        expect_as_single_steps(sim, op, p, x, y, force, at, 100, 4, 5, 9);
    }
}

// Runs of blocks in one parallel region (step_block's `blocks`): where no
// force and nothing but the receivers falls for many steps, a Simulation on
// a team runs several blocks at a time. Against the engine stepped one step
// at a time: the same bits in every trace, lattice frame and the final field,
// with forces early and late, scans and lattice frames at long intervals.
TEST(EngineMirrorEdges, ASimulationOnATeamRunsBlocksInARowBitForBit)
{
    const int ny = 2 * calib::engine::block_min_rows_per_thread + 5;
    for (Precision p : {Precision::f32, Precision::f64})
        for (int threads : {1, 2}) {
            auto op = make_plate(11, ny, 0.01, Edges::all(EdgeKind::simply_supported), 0.3, Loss{2.0, 5e-4});
            SimulationOptions o;
            o.precision = p;
            o.field_check_interval = 48;
            o.engine.threads = threads;
            o.engine.parallel_min_cells = 0;
            Simulation sim(op, o);
            std::vector<double> force(400, 0.0);
            for (int n : {0, 3, 150, 151, 399})
                force[std::size_t(n)] = std::cos(0.3 * n) + 0.5;
            const double x = 0.04, y = 0.3;
            sim.set_source_signal(sim.add_source(x, y), force);
            // One receiver beside the seam (rows ny / 2 +- 1), two elsewhere.
            const std::vector<std::pair<double, double>> at = {
                {0.05, 0.01 * (ny / 2) + 0.004}, {0.07, 0.01 * (ny / 2) - 0.006}, {0.02, 0.05}};
            for (auto [rx, ry] : at)
                sim.add_receiver(rx, ry);
            sim.record_lattice(5, 100, 77);
            for (int run : {5, 200, 195, 100})
                sim.run(std::size_t(run));
            SCOPED_TRACE(std::to_string(threads) + " threads");
            expect_as_single_steps(sim, op, p, x, y, force, at, 500, 5, 100, 77);
        }
}
