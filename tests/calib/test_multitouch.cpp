// Several fingers: the firmware's mixer gain against hand-computed energies
// and block peaks, and every pair and triple of a small plate's foci played
// superposed and designed jointly, each within the superposition's budget.
#include "pipeline/calibrate.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/verification/multitouch.h"
#include "pipeline/verification/verification.h"
#include "pipeline/transfer/transfer.h"
#include "scene/calibration_input.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "scene_text.h"

using namespace calib;

namespace {

// A small lossy acrylic plate, four fixed exciters, 2 x 2 foci.
const std::string plate_scene = scene_text::load("inverse.toml");

// The inverse filter's table at a 6 ms lead time on `in`'s plate: H (foci
// and lattice) and the calibration's signals and verification on it.
struct Table {
    pipeline::TransferMatrix H;
    pipeline::CalibrationResult r;
};
Table inverse_filter_table(pipeline::CalibrationInput &in)
{
    in.calibration.lead_time_s = 0.006;
    in.calibration.method = pipeline::DriveMethod::inverse_filter;
    Table t{pipeline::transfer_for(in, in.exciters.positions), {}};
    t.r.exciters = in.exciters.positions;
    pipeline::signals_and_verification(in, t.H, {}, t.r);
    return t;
}

} // namespace

TEST(MultiTouch, MixerGainHoldsTheMeanSingleFocusEnergyAndNeverClips)
{
    // Two channels, 256 frames. a and b: equal energy, orthogonal (different
    // channels): E_sum = 2 E, E_ref = E, g = 1/sqrt(2). a with itself: the sum
    // is 2a, E_sum = 4 E, g = 1/2. A loud pair whose sum would clip: the peak
    // bound (64-frame blocks, sum of block peaks) wins.
    const unsigned C = 2;
    std::vector<int16_t> a(512, 0), b(512, 0), loud(512, 0);
    for (std::size_t n = 0; n < 256; n++) {
        a[n * C] = static_cast<int16_t>(n % 2 ? 1000 : -1000);
        b[n * C + 1] = static_cast<int16_t>(n % 3 ? 1000 : -1000);
        loud[n * C] = static_cast<int16_t>(n == 10 ? 30000 : 0);
    }
    EXPECT_DOUBLE_EQ(pipeline::mixer_gain({&a}, C), 1.0);
    EXPECT_NEAR(pipeline::mixer_gain({&a, &b}, C), 1 / std::sqrt(2.0), 1e-12);
    EXPECT_NEAR(pipeline::mixer_gain({&a, &a}, C), 0.5, 1e-12);
    // loud + loud: energy says 1/2 too, the peak bound 32767 / 60000.
    EXPECT_NEAR(pipeline::mixer_gain({&loud, &loud}, C), 0.5, 1e-12);
    std::vector<int16_t> loud2(512, 0);
    loud2[20 * C] = 30000; // same block, same channel, orthogonal in time: energy 1/sqrt(2), peak 32767/60000
    EXPECT_NEAR(pipeline::mixer_gain({&loud, &loud2}, C), 32767.0 / 60000.0, 1e-12);
}

TEST(MultiTouch, PairsAndTriplesKeepTheSuperpositionsBudgetJointOrSuperposed)
{
    // Every pair and triple of the 2 x 2 foci, superposed and designed
    // jointly: the mix never has more energy than the mean of its foci alone
    // (the firmware's normalisation), the joint drive never more than the
    // mix, no touched focus of the joint drive exceeds the scene's amplitude
    // (and the cap scales the field when it binds), and a set of one
    // designed jointly is the table's design.
    pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    in.calibration.dither = false;
    const Table t = inverse_filter_table(in);
    const pipeline::TransferMatrix &H = t.H;
    const pipeline::CalibrationResult &r = t.r;
    std::vector<std::vector<int16_t>> stored;
    std::vector<double> energy;
    for (const auto &d : r.signals) {
        stored.push_back(d.samples);
        double e = 0;
        for (int16_t v : d.samples)
            e += double(v) * double(v);
        energy.push_back(e);
    }
    const auto single = pipeline::joint_inverse_filter_signals(in, H, {1});
    const auto table = pipeline::inverse_filter_signals(in, H);
    ASSERT_EQ(single.normalized.size(), table[1].normalized.size());
    for (std::size_t i = 0; i < single.normalized.size(); i++)
        ASSERT_EQ(single.normalized[i], table[1].normalized[i]) << i;

    pipeline::MultiTouchOptions mo;
    mo.triples = mo.joint = true;
    const pipeline::MultiTouchReport rep =
        pipeline::verify_multitouch(in, H, stored, in.calibration.output_rate_hz, mo);
    std::size_t pairs = 0, triples = 0;
    double quietest = INFINITY;
    for (const pipeline::MultiTouchCase &c : rep.cases) {
        ASSERT_TRUE(c.has_joint);
        (c.foci.size() == 2 ? pairs : triples)++;
        double e_ref = 0;
        for (std::size_t f : c.foci)
            e_ref += energy[f] / double(c.foci.size());
        // The firmware's normalisation: at most the mean energy of the foci alone.
        EXPECT_LE(c.superposed.energy, e_ref * (1 + 1e-6));
        // The joint drive: at most what the mix plays, and no touched focus
        // above the scene's amplitude.
        EXPECT_LE(c.joint.energy, c.superposed.energy * (1 + 1e-6));
        EXPECT_GT(c.joint.min_focus_peak_m, 0.0);
        EXPECT_LE(c.joint.min_focus_peak_m, c.joint.max_focus_peak_m);
        EXPECT_LE(c.joint.max_focus_peak_m, in.pulse.amplitude_m * (1 + 1e-6));
        quietest = std::min(quietest, c.joint.max_focus_peak_m);
    }
    // 2 x 2 foci more than lambda/2 (36 mm) apart: all 6 pairs, all 4 triples.
    EXPECT_EQ(pairs, 6u);
    EXPECT_EQ(triples, 4u);

    // The amplitude cap, exercised: with the scene's amplitude at half the
    // quietest joint drive's loudest focus every joint drive is turned down
    // until its loudest touched focus is exactly that amplitude, the field
    // and the energy scaled with the gain (the field is linear in it); the
    // superposition does not move.
    pipeline::CalibrationInput low = in;
    low.pulse.amplitude_m = 0.5 * quietest;
    const pipeline::MultiTouchReport capped =
        pipeline::verify_multitouch(low, H, stored, in.calibration.output_rate_hz, mo);
    ASSERT_EQ(capped.cases.size(), rep.cases.size());
    for (std::size_t i = 0; i < rep.cases.size(); i++) {
        const pipeline::SetVerdict &a = rep.cases[i].joint, &b = capped.cases[i].joint;
        const double k = b.gain / a.gain;
        EXPECT_LT(k, 0.5 + 1e-6) << i;
        EXPECT_NEAR(b.max_focus_peak_m, low.pulse.amplitude_m, 1e-4 * low.pulse.amplitude_m) << i;
        EXPECT_NEAR(b.min_focus_peak_m, k * a.min_focus_peak_m, 1e-4 * b.min_focus_peak_m) << i;
        EXPECT_NEAR(b.max_elsewhere_m, k * a.max_elsewhere_m, 1e-4 * b.max_elsewhere_m) << i;
        EXPECT_NEAR(b.energy, k * k * a.energy, 1e-4 * b.energy) << i;
        EXPECT_EQ(capped.cases[i].superposed.energy, rep.cases[i].superposed.energy) << i;
    }
    // A robust table has no joint counterpart (the joint design is of the nominal plate): refused.
    pipeline::CalibrationInput robust = in;
    robust.robust = pipeline::RobustSpec{};
    EXPECT_THROW(pipeline::verify_multitouch(robust, H, stored, in.calibration.output_rate_hz, mo),
                 std::invalid_argument);
}

TEST(MultiTouch, AJointSetOfOneIsTheTablesDesignWithThePrecompensatedExciter)
{
    // With [effects.exciter] precompensate the table's drives are
    // pre-compensated for the exciter; a joint design must be too, or the
    // comparison is of two different devices. A set of one: the same
    // normalised drive as the stored focus, before dither.
    pipeline::CalibrationInput in = scene::calibration_input(
        plate_scene + "[effects.exciter]\nmoving_mass_kg = 0.03\nstiffness_n_m = 1.0e5\ndamping_n_s_m = 25\n"
                      "force_factor_n_a = 3.2\nprecompensate = true\nmax_boost_db = 12\n",
        "inverse.toml");
    ASSERT_TRUE(in.effects.exciter && in.effects.exciter->precompensate);
    const Table t = inverse_filter_table(in);
    const pipeline::TransferMatrix &H = t.H;
    const pipeline::CalibrationResult &r = t.r;
    const pipeline::DriveSignals one = pipeline::joint_inverse_filter_signals(in, H, {2});
    const pipeline::DriveSignals plain = pipeline::inverse_filter_signals(in, H)[2]; // not pre-compensated
    ASSERT_EQ(one.normalized.size(), r.signals[2].normalized.size());
    double diff = 0, moved = 0;
    for (std::size_t i = 0; i < one.normalized.size(); i++) {
        diff = std::max(diff, std::abs(one.normalized[i] - r.signals[2].normalized[i]));
        moved = std::max(moved, std::abs(one.normalized[i] - plain.normalized[i]));
    }
    EXPECT_LT(diff, 1e-12);
    EXPECT_GT(moved, 0.01); // the pre-compensation changes the drive
}
