// Hard inputs that must stay stable and be reported: sources and receivers
// on edge and corner nodes (hand-computed energies, reciprocity), zero and
// extreme loss, and non-finite values caught at once with step and place.
#include "engine/simulation.h"
#include "test_stability_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

using namespace plate_test;

// ---- sources and receivers on edge and corner nodes ----

TEST(StabilityBoundaryPoints, ImpulseOnEdgeAndCornerNodesInjectsTheHandComputedEnergy)
{
    // A 1 N s impulse on a node of mass M = rho d h^2 w (w = 1 inside, 1/2 on
    // a free edge, 1/4 at a free corner) gives it velocity 1/M: the discrete
    // energy after the first step is exactly 1/(2M); on a supported node it is
    // 0. Then 0.99 x the bound keeps it.
    const Edges e{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    auto op = make_plate(20, 15, 0.01, e); // left and bottom free: corner (0, 0) is a free corner
    const double lx = 0.2, ly = 0.15;
    const double m1 = test_material().density_kg_m3 * 0.002 * 0.01 * 0.01;
    struct Case {
        const char *name;
        double x, y, w;
    } cases[] = {
        {"interior node", 0.1, 0.07, 1.0},
        {"free edge node (left)", 0.0, 0.07, 0.5},
        {"free edge node (bottom)", 0.1, 0.0, 0.5},
        {"free corner node", 0.0, 0.0, 0.25},
        {"clamped edge node (right)", lx, 0.07, 0.0},
        {"simply supported edge node (top)", 0.1, ly, 0.0},
        {"clamped/free corner (right, bottom)", lx, 0.0, 0.0},
        {"free/simply supported corner (left, top)", 0.0, ly, 0.0},
    };
    for (const Case &c : cases) {
        SimulationOptions opt;
        opt.precision = Precision::f64;
        opt.time_step_s = 0.99 * op->max_time_step();
        Simulation sim(op, opt);
        sim.set_source_impulse(sim.add_source(c.x, c.y));
        sim.add_receiver(c.x, c.y); // the same node: reads the boundary directly
        sim.add_receiver(0.13, 0.09);
        sim.run(1);
        const double expect = c.w > 0 ? 1 / (2 * m1 * c.w) : 0.0;
        EXPECT_NEAR(sim.energy(), expect, 1e-12 * (expect + 1e-300)) << c.name;
        sim.run(scaled(20000));
        if (c.w > 0) {
            EXPECT_NEAR(sim.energy() / expect, 1.0, 1e-10) << c.name;
            EXPECT_GT(max_abs(sim.traces()[1]), 0) << c.name;
        } else {
            // A supported node takes no force and reads zero, exactly.
            EXPECT_EQ(sim.energy(), 0.0) << c.name;
            EXPECT_EQ(max_abs(sim.traces()[0]), 0.0) << c.name;
            EXPECT_EQ(max_abs(sim.traces()[1]), 0.0) << c.name;
        }
    }
}

TEST(StabilityBoundaryPoints, CornerAndEdgeSourcesAndReceiversAreReciprocal)
{
    // Free corner -> free-edge receiver equals the reverse to round-off (the
    // reciprocity test covers interior points only), lossy, float and double.
    const Edges e{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    auto op = make_plate(24, 18, 0.01, e, 0.3, Loss{3.0, 2e-4});
    const double a[2] = {0.0, 0.0}, b[2] = {0.137, 0.0}; // corner node; off-node on the bottom edge
    for (Precision p : {Precision::f64, Precision::f32}) {
        auto trace = [&](const double *src, const double *rec) {
            SimulationOptions opt;
            opt.precision = p;
            opt.courant = 0.99;
            Simulation sim(op, opt);
            sim.set_source_impulse(sim.add_source(src[0], src[1]));
            sim.add_receiver(rec[0], rec[1]);
            sim.run(scaled(3000));
            return sim.traces()[0];
        };
        const auto ab = trace(a, b), ba = trace(b, a);
        const double peak = max_abs(ab);
        ASSERT_GT(peak, 0);
        double err = 0;
        for (std::size_t n = 0; n < ab.size(); ++n)
            err = std::max(err, std::abs(ab[n] - ba[n]));
        EXPECT_LT(err / peak, p == Precision::f64 ? 1e-11 : 1e-4) << precision_name(p);
    }
}

// ---- loss ----

TEST(StabilityLoss, ZeroLossIsTheLosslessSchemeBitForBit)
{
    // Loss{0, 0} is not "almost lossless": the lossless kernel runs and the
    // energy is conserved as without a [plate.loss] section.
    const Edges e{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    auto a = make_plate(14, 11, 0.01, e, 0.3, Loss{0.0, 0.0});
    auto b = make_plate(14, 11, 0.01, e);
    EXPECT_EQ(a->max_time_step(), b->max_time_step());
    const double k = 0.99 * a->max_time_step();
    PlateEngine<double> ea(a, k), eb(b, k);
    ea.set_state(random_field(*a, 5), random_field(*a, 6));
    eb.set_state(random_field(*b, 5), random_field(*b, 6));
    const double e0 = ea.energy();
    for (std::size_t n = 0; n < scaled(50000); ++n) {
        ea.step();
        eb.step();
    }
    EXPECT_EQ(ea.displacement(), eb.displacement());
    EXPECT_LE(std::abs(ea.energy() / e0 - 1), 1e-11);
}

namespace {

// Impulse at an interior point, energy checked after every step: returns
// the final energy over the energy after the first step (or -1 on a rise).
template <typename T>
double impulse_energy_ratio(std::shared_ptr<const PlateOperator> op, std::size_t steps, double rise_tol)
{
    PlateEngine<T> eng(op, 0.99 * op->max_time_step());
    const std::size_t s = eng.add_source(0.07, 0.05);
    eng.add_receiver(0.0, 0.12); // free corner
    eng.set_source_force(s, 1 / eng.time_step());
    ScopedFlushDenormals ftz;
    eng.step();
    eng.set_source_force(s, 0.0);
    const double e0 = eng.energy();
    double prev = e0;
    for (std::size_t n = 0; n < steps; ++n) {
        eng.step();
        const double now = eng.energy();
        if (!(now <= prev * (1 + rise_tol)) || !std::isfinite(eng.receiver_value(0))) {
            ADD_FAILURE() << "energy rose or went non-finite at step " << n << ": " << prev << " -> " << now;
            return -1;
        }
        prev = now;
    }
    return prev / e0;
}

} // namespace

TEST(StabilityLoss, VeryHighLossDecaysMonotonicallyAndStaysFinite)
{
    // sigma0 k = 50 (overdamped far beyond any physical plate) and a sigma1
    // that takes the time step down to a quarter of the lossless bound: the
    // energy never increases (checked every step), falls by orders of
    // magnitude, and nothing overflows. (Overdamped, the slow modes creep
    // back to rest at omega^2 / (2 sigma0): the fall is that of the kinetic
    // energy, hence 1e-2 and not more.)
    const Edges e{EdgeKind::free, EdgeKind::free, EdgeKind::clamped, EdgeKind::free};
    auto lossless = make_plate(16, 12, 0.01, e);
    const double k0 = lossless->max_time_step();
    // k^2/4 lambda_K + sigma1 k lambda_G = 1 at k = k0/4: sigma1 = (1 - 1/16) / (k lambda_G).
    const double lambda_g = make_plate(16, 12, 0.01, e, 0.3, Loss{0, 1e-6})->lambda_max_dirichlet();
    const double sigma1 = (1 - 1.0 / 16) / (k0 / 4 * lambda_g);
    for (const Loss loss : {Loss{50 / (0.99 * k0), 0.0}, Loss{0.0, sigma1}, Loss{50 / (0.99 * k0 / 4), sigma1}}) {
        auto op = make_plate(16, 12, 0.01, e, 0.3, loss);
        if (loss.sigma1 > 0) {
            EXPECT_NEAR(op->max_time_step() / (k0 / 4), 1.0, 1e-9);
        }
        const std::size_t steps = 4000; // not scaled: the overdamped fall needs them (0.5 s under ASan)
        const double r64 = impulse_energy_ratio<double>(op, steps, 1e-12);
        const double r32 = impulse_energy_ratio<float>(op, steps, 1e-5);
        EXPECT_TRUE(r64 >= 0 && r64 < 1e-2) << "sigma0 " << loss.sigma0 << " sigma1 " << loss.sigma1 << ": " << r64;
        EXPECT_TRUE(r32 >= 0 && r32 < 1e-2) << "sigma0 " << loss.sigma0 << " sigma1 " << loss.sigma1 << ": " << r32;
    }
}
// ---- non-finite values: detected at once, with step and place ----

namespace {

std::string run_expecting_failure(Simulation &sim, std::size_t steps)
{
    try {
        sim.run(steps);
    } catch (const std::runtime_error &e) {
        return e.what();
    }
    ADD_FAILURE() << "no error";
    return {};
}

bool has(const std::string &s, const std::string &part) { return s.find(part) != std::string::npos; }

} // namespace

TEST(StabilityNonFinite, NanOrInfSourceForceIsRefusedAtItsStepBeforeReachingTheField)
{
    auto op = make_plate(20, 15, 0.01, Edges::all(EdgeKind::free));
    for (Precision p : {Precision::f32, Precision::f64})
        for (double bad : {std::nan(""), std::numeric_limits<double>::infinity(), -1e300}) {
            if (p == Precision::f64 && bad == -1e300)
                continue; // finite in double: not an error
            SimulationOptions opt;
            opt.precision = p;
            Simulation sim(op, opt);
            sim.add_source(0.05, 0.05);
            const std::size_t s = sim.add_source(0.1, 0.07);
            sim.add_receiver(0.15, 0.1);
            sim.run(7); // the signal starts at step 7
            std::vector<double> f(200, 0.5);
            f[100] = bad;
            sim.set_source_signal(s, f);
            const std::string m = run_expecting_failure(sim, 500);
            EXPECT_TRUE(has(m, "source 1")) << m;
            EXPECT_TRUE(has(m, "at step 107 ")) << m;
            EXPECT_TRUE(has(m, "sample 100 ")) << m;
            EXPECT_TRUE(has(m, "t = ")) << m;
            EXPECT_TRUE(has(m, bad == -1e300 ? "float" : (std::isnan(bad) ? "nan" : "inf"))) << m;
            // Nothing non-finite was written: traces stop before the step.
            ASSERT_EQ(sim.traces()[0].size(), 107u);
            for (double v : sim.traces()[0])
                ASSERT_TRUE(std::isfinite(v));
            EXPECT_TRUE(std::isfinite(sim.energy()));
            for (double v : sim.snapshot())
                ASSERT_TRUE(std::isfinite(v));
            // And it refuses to go on.
            const std::string again = run_expecting_failure(sim, 1);
            EXPECT_TRUE(has(again, "source 1")) << again;
        }
}

namespace {

// Independent reference: the same engine stepped alone, the whole field
// scanned after every step. Returns the 0-based step whose output first holds
// a non-finite node, and that node (first in row order).
struct FirstBad {
    std::size_t step = 0;
    int i = -1, j = -1;
};
FirstBad reference_divergence(std::shared_ptr<const PlateOperator> op, double k, double x, double y)
{
    EngineOptions unchecked;
    unchecked.skip_stability_check = true;
    PlateEngine<double> eng(op, k, unchecked);
    eng.add_source(x, y);
    eng.set_source_force(0, 1 / k);
    const int w = op->grid().nx + 1;
    for (std::size_t n = 0; n < 100000; ++n) {
        eng.step();
        eng.set_source_force(0, 0.0);
        const auto u = eng.displacement();
        for (std::size_t node = 0; node < u.size(); ++node)
            if (!std::isfinite(u[node]))
                return {n, int(node % std::size_t(w)), int(node / std::size_t(w))};
    }
    ADD_FAILURE() << "reference did not diverge";
    return {};
}

} // namespace

TEST(StabilityNonFinite, DivergenceIsReportedWithStepTimeAndNode)
{
    // Beyond the bound (check bypassed) the field overflows to Inf and NaN.
    // With a whole-field scan every step the reported step and node are
    // exactly those of an independent per-step scan; with the default interval
    // (16) the report comes within 16 steps and names the last clean scan;
    // with receivers only (interval 0) the receiver that first sees it.
    const Edges e{EdgeKind::free, EdgeKind::clamped, EdgeKind::free, EdgeKind::simply_supported};
    auto op = make_plate(20, 15, 0.01, e);
    const double k = 1.3 * op->max_time_step();
    const FirstBad ref = reference_divergence(op, k, 0.1, 0.07);
    for (std::size_t interval : {std::size_t(1), std::size_t(16), std::size_t(0)}) {
        SimulationOptions opt;
        opt.precision = Precision::f64;
        opt.time_step_s = k;
        opt.engine.skip_stability_check = true;
        opt.field_check_interval = interval;
        Simulation sim(op, opt);
        sim.set_source_impulse(sim.add_source(0.1, 0.07));
        sim.add_receiver(0.19, 0.14);
        const std::string m = run_expecting_failure(sim, ref.step + 1000);
        EXPECT_TRUE(has(m, "simulation diverged")) << m;
        EXPECT_TRUE(has(m, "node (i, j) = (")) << m;
        EXPECT_TRUE(has(m, "t = ")) << m;
        const std::size_t reported = sim.traces()[0].size();
        for (double v : sim.traces()[0])
            ASSERT_TRUE(std::isfinite(v));
        if (interval == 1) {
            EXPECT_TRUE(has(m, "at step " + std::to_string(ref.step) + " ")) << m << " expected step " << ref.step;
            EXPECT_TRUE(has(m, "(i, j) = (" + std::to_string(ref.i) + ", " + std::to_string(ref.j) + ")")) << m;
            EXPECT_TRUE(has(m, "(x, y) = (")) << m;
            // Found by the scan, the finite receiver sample of that step is
            // kept; found by the receiver, it is not.
            EXPECT_TRUE(reported == ref.step + 1 || reported == ref.step) << reported;
        } else if (interval == 16) {
            const std::size_t at = ((ref.step + 1 + 15) / 16) * 16 - 1; // next scan after ref.step
            EXPECT_TRUE(has(m, "at step " + std::to_string(at) + " ") || has(m, "receiver 0")) << m;
            EXPECT_TRUE(has(m, "finite after step")) << m;
        } else {
            EXPECT_TRUE(has(m, "detected by receiver 0")) << m;
            EXPECT_GE(reported, ref.step);
        }
    }
}

TEST(StabilityNonFinite, RunsOfBlocksOnATeamReportDivergenceAtTheScanSingleStepsWould)
{
    // Clamped and supported edges step in runs of blocks, many in one
    // parallel region, the whole-field scans inside it (Simulation::run,
    // PlateEngine::step_block's scan_after). The report must be the one the
    // scans of single steps give, to the byte: the first scan after the field
    // goes non-finite (every 16 steps), the field as it is there, and the
    // last clean scan before it. The reference: the engine alone, one
    // thread, single steps (the same bits: EngineMirrorEdges), its own
    // report at that step.
    const Edges e{EdgeKind::clamped, EdgeKind::simply_supported, EdgeKind::simply_supported, EdgeKind::clamped};
    auto op = make_plate(40, 70, 0.01, e, 0.3, Loss{2.0, 5e-5});
    const double k = 1.01 * op->max_time_step(), x = 0.13, y = 0.41;
    auto check = [&](auto zero, Precision precision) {
        using T = decltype(zero);
        EngineOptions unchecked;
        unchecked.skip_stability_check = true;
        PlateEngine<T> ref(op, k, unchecked);
        ref.add_source(x, y);
        ref.set_source_force(0, 1 / k);
        while (ref.non_finite_report().empty()) {
            ref.step();
            ref.set_source_force(0, 0.0);
            ASSERT_LT(ref.steps_done(), 100000u) << "the reference did not diverge";
        }
        const std::size_t first_bad = ref.steps_done() - 1, at = (first_bad / 16 + 1) * 16 - 1;
        ASSERT_GT(first_bad, 300u) << "diverged before a run of 64 blocks could pass a scan";
        while (ref.steps_done() < at + 1)
            ref.step();
        const std::string expected = "simulation diverged: " + ref.non_finite_report() +
                                     "; detected by the whole-field scan; the whole field was finite after step " +
                                     std::to_string(at - 16);
        for (int threads : {1, 2}) {
            SimulationOptions opt;
            opt.precision = precision;
            opt.time_step_s = k;
            opt.engine.skip_stability_check = true;
            opt.engine.threads = threads;
            opt.engine.parallel_min_cells = 0;
            Simulation sim(op, opt);
            sim.set_source_impulse(sim.add_source(x, y));
            EXPECT_EQ(run_expecting_failure(sim, at + 5000), expected) << threads << " threads";
            EXPECT_EQ(sim.steps_done(), at + 1) << threads << " threads";
        }
    };
    check(0.0f, Precision::f32);
    check(0.0, Precision::f64);
}

TEST(StabilityNonFinite, EndOfRunScanCatchesWhatNoReceiverSees)
{
    // No receivers, no periodic scan: the scan at the end of run() still
    // refuses to hand back a non-finite field.
    auto op = make_plate(20, 15, 0.01, Edges::all(EdgeKind::clamped));
    SimulationOptions opt;
    opt.precision = Precision::f32;
    opt.time_step_s = 1.3 * op->max_time_step();
    opt.engine.skip_stability_check = true;
    opt.field_check_interval = 0;
    Simulation sim(op, opt);
    sim.set_source_impulse(sim.add_source(0.1, 0.07));
    const std::string m = run_expecting_failure(sim, 5000);
    EXPECT_TRUE(has(m, "at the end of the run")) << m;
    EXPECT_TRUE(has(m, "at step 4999 ")) << m;
}
