// The safe range of a focus (data/verdict.h FocusMetrics::gain_range): the
// gains g, applied to the stored samples, at which the focus passes the
// verdict, lo <= g < hi. Each figure is checked against a value known without
// the code under test:
//  - SafeRangeRule: hand-built FocusMetrics, lo and hi worked out by hand
//    (threshold over the peak; threshold over the largest |w| the verdict
//    judges beyond lambda/2, the whole area only where it was measured), the
//    text every output prints, and at gain 1 the verdict itself: passes() ==
//    (lo <= 1 && 1 < hi) for figures on both sides of every comparison, to
//    the last bit;
//  - SafeRangeTable: real calibrations and their tables (verdict_ghost.h's
//    small scene, the regular exciter pattern): one stored at its 10 um
//    target that fails on its ghosts (both ends finite and below 1), one at
//    full scale that passes (the range straddles 1). The range two ways, for
//    both scopes: as the table stores it (computed from the metrics, i.e. the
//    stored drive scaled through H) against the verdict of the table's own
//    samples scaled by g just inside and just outside each end, re-quantized
//    to int16 and verified as `calibgen verify` verifies a table; at gain 1
//    the verdict of every focus; the range read back from the table, bit for
//    bit; no table without every focus's figures.
#include "pipeline/calibrate.h"
#include "pipeline/table_writer.h"
#include "pipeline/transfer/transfer.h"
#include "pipeline/verification/verification.h"
#include "scene/calibration_input.h"

#include <haptic_table.h>

#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "verdict_ghost.h"

namespace fs = std::filesystem;
using namespace calib;
using pipeline::FocusMetrics;

namespace {

constexpr double um = 1e-6, thr = 5 * um, inf = std::numeric_limits<double>::infinity();

// Figures as the verification sets them (verification.cpp): the booleans
// are its comparisons with the threshold.
FocusMetrics measured(double peak_m, double others_m, double whole_m, bool whole_area, double threshold_m = thr)
{
    FocusMetrics m;
    m.peak_m = peak_m;
    m.max_other_foci_m = others_m;
    m.max_whole_area_m = whole_area ? whole_m : 0.0;
    m.whole_area = whole_area;
    m.crosses_threshold = m.peak_m >= threshold_m;
    m.others_below_threshold = m.max_other_foci_m < threshold_m;
    m.whole_area_below_threshold = m.max_whole_area_m < threshold_m;
    return m;
}

} // namespace

TEST(SafeRangeRule, ThresholdOverThePeakToThresholdOverWhatTheVerdictJudges)
{
    // 10 um at the focus, 3 um at another focus, 4 um elsewhere in the area.
    const haptic_gain_range a = measured(10 * um, 3 * um, 4 * um, true).gain_range(thr);
    EXPECT_DOUBLE_EQ(a.lo, 0.5);
    EXPECT_DOUBLE_EQ(a.hi, 1.25); // the area's 4 um, the larger
    EXPECT_EQ(pipeline::safe_range_text(a), "-6.0 .. +1.9");
    // The other focus the larger: it sets hi.
    EXPECT_DOUBLE_EQ(measured(10 * um, 4 * um, 2 * um, true).gain_range(thr).hi, 1.25);
    // Foci only (the forward path): the whole area is not judged, even with a figure in it.
    FocusMetrics fwd = measured(10 * um, 2 * um, 0, false);
    fwd.max_whole_area_m = 8 * um;
    EXPECT_DOUBLE_EQ(fwd.gain_range(thr).hi, 2.5);
    // Nothing judged beyond lambda/2 moves: unbounded.
    const haptic_gain_range u = measured(10 * um, 0, 0, false).gain_range(thr);
    EXPECT_DOUBLE_EQ(u.lo, 0.5);
    EXPECT_EQ(u.hi, inf);
    EXPECT_EQ(pipeline::safe_range_text(u), "-6.0 .. unbounded");
    // A peak below the threshold, nothing near it: passes louder.
    const haptic_gain_range l = measured(4 * um, 1 * um, 2 * um, true).gain_range(thr);
    EXPECT_DOUBLE_EQ(l.lo, 1.25);
    EXPECT_DOUBLE_EQ(l.hi, 2.5);
    EXPECT_TRUE(pipeline::any_gain_passes(l));
    EXPECT_EQ(pipeline::safe_range_text(l), "+1.9 .. +8.0");
    // The ghost as loud as the focus, or louder: no gain passes.
    for (double ghost : {10 * um, 12 * um}) {
        const haptic_gain_range n = measured(10 * um, 1 * um, ghost, true).gain_range(thr);
        EXPECT_FALSE(pipeline::any_gain_passes(n)) << ghost;
        EXPECT_EQ(pipeline::safe_range_text(n), "none");
    }
    // The threshold scales both ends.
    const haptic_gain_range t2 = measured(10 * um, 3 * um, 4 * um, true).gain_range(2 * thr);
    EXPECT_DOUBLE_EQ(t2.lo, 1.0);
    EXPECT_DOUBLE_EQ(t2.hi, 2.5);
}

TEST(SafeRangeRule, GainsNoTableHoldsAreNoneADevicePlays)
{
    // Past HAPTIC_TABLE_RANGE_MAX_GAIN (1e6, 120 dB) every nonzero int16
    // sample clips: hi there is unbounded; a lo there passes at no gain.
    const haptic_gain_range far = measured(10 * um, 1e-13, 0, false).gain_range(thr); // hi 5e7
    EXPECT_DOUBLE_EQ(far.lo, 0.5);
    EXPECT_EQ(far.hi, inf);
    const haptic_gain_range at = measured(10 * um, 5e-12, 0, false).gain_range(thr); // hi 1e6, held
    EXPECT_LE(at.hi, HAPTIC_TABLE_RANGE_MAX_GAIN);
    EXPECT_GT(at.hi, 0.99e6);
    const haptic_gain_range still = measured(1e-13, 0, 0, false).gain_range(thr); // lo 5e7
    EXPECT_EQ(still.lo, HAPTIC_TABLE_RANGE_MAX_GAIN);
    EXPECT_EQ(still.hi, HAPTIC_TABLE_RANGE_MAX_GAIN);
    EXPECT_EQ(pipeline::safe_range_text(still), "none");
    const haptic_gain_range zero = measured(0, 0, 0, true).gain_range(thr);
    EXPECT_FALSE(pipeline::any_gain_passes(zero));
}

// At gain 1 the range is the verdict, bit for bit: figures on both sides of
// every comparison (equal to the threshold, one ulp either side), and many at
// random, for both scopes.
TEST(SafeRangeRule, AtGainOneItIsTheVerdict)
{
    std::vector<double> near{0, thr, std::nextafter(thr, 0.0), std::nextafter(thr, 1.0), 0.5 * thr, 2 * thr};
    const std::vector<double> thresholds{thr, 1e-6, 3.3e-6, 7.77e-6};
    std::size_t passing = 0, failing = 0;
    auto check = [&](const FocusMetrics &m, double t) {
        const haptic_gain_range r = m.gain_range(t);
        ASSERT_EQ(m.passes(), r.lo <= 1 && 1 < r.hi)
            << "peak " << m.peak_m << " others " << m.max_other_foci_m << " area " << m.max_whole_area_m
            << " whole_area " << m.whole_area << " threshold " << t << ": [" << r.lo << ", " << r.hi << ")";
        (m.passes() ? passing : failing)++;
    };
    for (double peak : near)
        for (double others : near)
            for (double whole : near)
                for (bool whole_area : {true, false})
                    check(measured(peak, others, whole, whole_area), thr);
    std::mt19937_64 rng(20261127);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    for (int k = 0; k < 200000; k++) {
        const double t = thresholds[std::size_t(k) % thresholds.size()];
        // Figures within a few per cent of the threshold, and a few one ulp off it.
        auto figure = [&] {
            const double x = t * (0.9 + 0.2 * unit(rng));
            const unsigned pick = unsigned(rng() % 8);
            return pick == 0 ? t : pick == 1 ? std::nextafter(t, 0.0) : pick == 2 ? std::nextafter(t, 1.0) : x;
        };
        check(measured(figure(), (k % 2 ? 0.5 : 1.0) * figure(), figure(), k % 3 != 0, t), t);
    }
    EXPECT_GT(passing, 1000u);
    EXPECT_GT(failing, 1000u);
}

// ---------------------------------------------------------------------------
// Real tables.
namespace {

constexpr double e = 0.02; // the step either side of an end: covers the int16 re-quantization (below)

struct TableCase {
    pipeline::CalibrationInput in;
    pipeline::CalibrationResult result;
    std::string table;                        // the table write_table wrote
    std::vector<pipeline::Point> exciters;    // read back from it
    std::vector<std::vector<int16_t>> stored; // its samples, [focus][frame * channels + c]
    pipeline::TransferMatrix H;               // of its exciters, as `calibgen verify` simulates it
    double rate_hz = 0;
};

std::string table_path(const std::string &name)
{
    return (fs::temp_directory_path() / ("haptic-safe-range-" + std::to_string(::getpid()) + "-" + name + ".htab"))
        .string();
}

// verdict_ghost's scene (0.25 x 0.2 m acrylic, 2 foci, the regular pattern
// of 4 exciters: no search, well under a second), calibrated and written
// with `force_full_scale_n`: its full-scale focal peaks are about 13 um at
// 0.5 N and proportional to the force.
TableCase build(const std::string &name, const std::string &force_n)
{
    TableCase k;
    std::string text = verdict_ghost::scene_text("10e-6");
    const std::string force = "force_full_scale_n = 0.5\n";
    text.replace(text.find(force), force.size(), "force_full_scale_n = " + force_n + "\n");
    k.in = scene::calibration_input(text, "verdict-regular.toml");
    k.result = pipeline::calibrate(k.in);
    k.table = table_path(name);
    pipeline::write_table(k.table, k.in, k.result);
    haptic_table t{};
    haptic_table_error err{};
    EXPECT_EQ(haptic_table_open(k.table.c_str(), &t, &err), 0) << err.message;
    k.rate_hz = t.sample_rate_hz;
    k.exciters.resize(t.channel_count);
    for (uint32_t ch = 0; ch < t.channel_count; ch++)
        haptic_table_channel_position(&t, ch, &k.exciters[ch].x_m, &k.exciters[ch].y_m);
    for (uint32_t f = 0; f < t.focus_count; f++) {
        const int16_t *s = haptic_table_signal(&t, f);
        k.stored.emplace_back(s, s + std::size_t(t.samples_per_signal) * t.channel_count);
    }
    haptic_table_close(&t);
    k.H = pipeline::transfer_for(k.in, k.exciters);
    return k;
}

// At 0.5 N each focus is stored at its 10 um target and fails on a ghost of
// about 7.7 um: lo about 0.5, hi about 0.65, both finite and below 1, so
// the table is scaled down only (nothing clips, the threshold stays).
const TableCase &ghosted()
{
    static const TableCase c = build("ghosted", "0.5");
    return c;
}

// At 0.21 N the exciters cannot reach 10 um: each focus is stored at full
// scale with a peak of 5.3-5.7 um and passes (its ghost 4.1-4.4 um): lo
// 0.88-0.94, hi 1.15-1.22, the range straddles 1, and the steps about hi
// lie above full scale (the threshold lowered instead, verify_scaled).
const TableCase &full_scale()
{
    static const TableCase c = build("full-scale", "0.21");
    return c;
}

struct Scaled {
    pipeline::Verification v;
    double k = 1; // played at gains / k against the threshold / k
};

// The verdict of the table's samples, focus f played at gains[f]: each sample
// times the gain, rounded to int16 as a device scaling the table would, then
// the verification `calibgen verify` runs on a table (verify_signals: H of
// the table's exciters, here simulated once, then verify_signals_with).
// Each focus is measured from its own drive alone, so one verification
// judges every focus at its own gain. A gain that would push a sample past
// full scale would clip, which no linear range describes: then every gain
// and the threshold are divided by one factor k that brings the loudest
// sample to full scale. Every |w| is linear in the drive, so at gain g / k
// against threshold / k the verdict is the one at gain g against the
// threshold (the whole-area refinement picks its candidates at 0.8 of the
// threshold or of the largest sample, a scale-free choice). The rounding to
// int16 is half a count on drives whose loudest sample is 10^4 counts or
// more (checked): 1e-4 of them or less, far inside the 2 % steps.
Scaled verify_scaled(const TableCase &c, const std::vector<double> &gains, bool whole_area)
{
    Scaled s;
    for (std::size_t f = 0; f < gains.size(); f++) {
        int peak = 0;
        for (int16_t x : c.stored[f])
            peak = std::max(peak, std::abs(int(x)));
        s.k = std::max(s.k, gains[f] * peak / 32767.0);
    }
    std::vector<std::vector<int16_t>> scaled = c.stored;
    for (std::size_t f = 0; f < gains.size(); f++) {
        int loudest = 0;
        for (int16_t &x : scaled[f]) {
            const long q = std::lround(double(x) * gains[f] / s.k);
            EXPECT_LE(std::labs(q), 32767); // never clipped
            x = static_cast<int16_t>(q);
            loudest = std::max(loudest, std::abs(int(x)));
        }
        EXPECT_GE(loudest, 10000) << "focus " << f << ": the re-quantization would not be small";
    }
    pipeline::CalibrationInput in = c.in;
    in.calibration.threshold_m /= s.k;
    s.v = pipeline::verify_signals_with(in, c.H, scaled, c.rate_hz, {}, whole_area);
    return s;
}

// The safe range two ways, for both scopes. Way 1: from the metrics of the
// stored drive played through H (whole area: the calibration's own, which
// the table stores; foci only: what the forward path's verdict judges).
// Way 2: the verdict of the table's samples scaled to just inside and just
// outside each end. `passes_as_stored`: the verdict at gain 1 of every focus.
void check_two_ways(const TableCase &c, bool passes_as_stored)
{
    const double threshold = c.in.calibration.threshold_m;
    const std::size_t K = c.in.foci.points.size();
    ASSERT_EQ(K, 2u);
    ASSERT_EQ(c.stored.size(), K);
    for (std::size_t f = 0; f < K; f++) // the table holds the calibration's samples
        ASSERT_TRUE(
            std::equal(c.result.signals[f].samples.begin(), c.result.signals[f].samples.end(), c.stored[f].begin()));

    for (bool whole_area : {true, false}) {
        SCOPED_TRACE(whole_area ? "whole area" : "foci only");
        const pipeline::Verification way1 =
            whole_area ? c.result.verification
                       : pipeline::verify_signals_with(c.in, c.H, c.stored, c.rate_hz, {}, false);
        std::vector<haptic_gain_range> range;
        for (const FocusMetrics &m : way1.foci) {
            ASSERT_EQ(m.whole_area, whole_area);
            range.push_back(m.gain_range(threshold));
            const haptic_gain_range &r = range.back();
            SCOPED_TRACE("focus " + std::to_string(m.id) + ": [" + std::to_string(r.lo) + ", " + std::to_string(r.hi) +
                         ")");
            // Both ends finite, and apart by more than the steps either side of them.
            ASSERT_TRUE(std::isfinite(r.hi));
            ASSERT_LT(r.lo * (1 + e), r.hi * (1 - e));
            // At gain 1, the verdict.
            EXPECT_EQ(m.passes(), passes_as_stored) << m.failure(threshold);
            EXPECT_EQ(m.passes(), r.lo <= 1 && 1 < r.hi);
        }

        struct Step {
            const char *what;
            bool at_hi;
            double factor;
            bool passes;
        };
        bool scaled_up = false;
        for (const Step &st : {Step{"just below lo", false, 1 - e, false}, Step{"just above lo", false, 1 + e, true},
                               Step{"just below hi", true, 1 - e, true}, Step{"just above hi", true, 1 + e, false}}) {
            SCOPED_TRACE(st.what);
            std::vector<double> gains;
            for (const haptic_gain_range &r : range)
                gains.push_back((st.at_hi ? r.hi : r.lo) * st.factor);
            const Scaled s = verify_scaled(c, gains, whole_area);
            scaled_up |= s.k > 1;
            for (std::size_t f = 0; f < K; f++) {
                const FocusMetrics &m = s.v.foci[f];
                SCOPED_TRACE("focus " + std::to_string(m.id) + " at gain " + std::to_string(gains[f]) + " (/" +
                             std::to_string(s.k) + ")");
                EXPECT_EQ(m.passes(), st.passes) << m.failure(threshold / s.k);
                // Which end: the peak at lo, what is judged beyond lambda/2 at hi.
                if (st.at_hi) {
                    EXPECT_TRUE(m.crosses_threshold);
                } else {
                    EXPECT_EQ(m.crosses_threshold, st.passes);
                }
                // Linear in the drive, to the re-quantization.
                EXPECT_NEAR(m.peak_m * s.k / gains[f], way1.foci[f].peak_m, 2e-3 * way1.foci[f].peak_m);
                // And at the gain it was played, the rule again gives the verdict.
                const haptic_gain_range here = m.gain_range(threshold / s.k);
                EXPECT_EQ(m.passes(), here.lo <= 1 && 1 < here.hi);
            }
        }
        // The ghosted table is only ever scaled down; the full-scale one is
        // scaled up past hi (through the lowered threshold).
        EXPECT_EQ(scaled_up, passes_as_stored);
    }
}

// write_table stores the range of every focus as the rule gives it, with
// the threshold and the scope it was judged at, bit for bit.
void check_stored(const TableCase &c)
{
    haptic_table t{};
    haptic_table_error err{};
    ASSERT_EQ(haptic_table_open(c.table.c_str(), &t, &err), 0) << err.message;
    EXPECT_EQ(haptic_table_range_threshold_m(&t), c.in.calibration.threshold_m);
    EXPECT_EQ(haptic_table_range_scope(&t), HAPTIC_RANGE_WHOLE_AREA);
    for (uint32_t f = 0; f < t.focus_count; f++) {
        const haptic_gain_range want = c.result.verification.foci[f].gain_range(c.in.calibration.threshold_m);
        haptic_gain_range got{-1, -1};
        EXPECT_EQ(haptic_table_gain_range(&t, f, &got), 0) << "focus " << f;
        EXPECT_EQ(got.lo, want.lo) << "focus " << f;
        EXPECT_EQ(got.hi, want.hi) << "focus " << f;
    }
    haptic_gain_range none{};
    EXPECT_EQ(haptic_table_gain_range(&t, t.focus_count, &none), -1); // no such focus
    haptic_table_close(&t);
}

} // namespace

TEST(SafeRangeTable, GhostedTableTheRangeIsTheVerdictOfTheScaledTable)
{
    check_two_ways(ghosted(), false);
    check_stored(ghosted());
}

TEST(SafeRangeTable, FullScaleTableTheRangeIsTheVerdictOfTheScaledTable)
{
    check_two_ways(full_scale(), true);
    check_stored(full_scale());
}

// Every figure a table stores per focus is the verification's: without every
// focus's figures write_table writes no table (and no range guessed for one).
TEST(SafeRangeTable, NoTableWithoutEveryFocussFigures)
{
    const TableCase &c = ghosted();
    pipeline::CalibrationResult r = c.result;
    r.verification.foci.pop_back();
    const std::string path = table_path("short");
    EXPECT_THROW(pipeline::write_table(path, c.in, r), std::runtime_error);
    EXPECT_FALSE(fs::exists(path));
}

// The tables live as long as the suite.
namespace {
struct RemoveTables : ::testing::Environment {
    void TearDown() override
    {
        std::error_code ec;
        for (const char *name : {"ghosted", "full-scale", "short"})
            fs::remove(table_path(name), ec);
    }
};
const auto *const remove_tables = ::testing::AddGlobalTestEnvironment(new RemoveTables);
} // namespace
