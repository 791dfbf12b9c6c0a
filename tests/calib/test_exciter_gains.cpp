// Time reversal's per-exciter gains (pipeline/design/exciter_gains.h): the
// minimax of the ghost rows under the focal constraint, against a brute-force
// search over the constraint's plane (a second method), and what the gains do
// in a calibration: a whole-area contrast at least the equal gains', the
// scene's amplitude kept.
#include "pipeline/calibrate.h"
#include "pipeline/design/exciter_gains.h"
#include "scene/calibration_input.h"
#include "scene_text.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

using namespace calib;

namespace {

// max_i |G_i . w|.
double largest(const Eigen::MatrixXf &G, const Eigen::VectorXd &w)
{
    return double((w.cast<float>().transpose() * G).cwiseAbs().maxCoeff());
}

} // namespace

// Three exciters: the constraint a . w = a . 1 leaves a plane of gains,
// searched on a fine grid around the equal gains; Lawson's result is within
// a fraction of a per cent of the grid's best and never above equal gains.
TEST(ExciterGains, MinimaxEqualsABruteForceSearchOfTheConstraintPlane)
{
    std::mt19937 rng(7);
    std::normal_distribution<float> n01(0.0f, 1.0f);
    double best_gain = 1;
    for (int trial = 0; trial < 4; trial++) {
        SCOPED_TRACE("trial " + std::to_string(trial));
        const Eigen::Index C = 3, N = 400;
        Eigen::MatrixXf G(C, N);
        for (Eigen::Index i = 0; i < N; i++)
            for (Eigen::Index c = 0; c < C; c++)
                G(c, i) = n01(rng) * (c == trial % 3 ? 3.0f : 1.0f); // one exciter makes the worst ghosts
        Eigen::VectorXd a(C);
        a << 2.0 + trial, 1.5, 1.0;
        const pipeline::ExciterGains g = pipeline::minimax_gains(G, a);
        ASSERT_EQ(g.gain.size(), 3u);
        const Eigen::Vector3d w(g.gain[0], g.gain[1], g.gain[2]);
        EXPECT_NEAR(a.dot(w), a.sum(), 1e-9 * a.sum()); // the focal value held
        EXPECT_NEAR(g.ratio, largest(G, w) / a.sum(), 1e-6);
        EXPECT_NEAR(g.equal_ratio, largest(G, Eigen::Vector3d::Ones()) / a.sum(), 1e-6);
        EXPECT_LE(g.ratio, g.equal_ratio);
        // The plane: w = 1 + s u + t v with u, v orthogonal to a.
        const Eigen::Vector3d u = Eigen::Vector3d(a[1], -a[0], 0).normalized();
        const Eigen::Vector3d v = Eigen::Vector3d(a[0], a[1], a[2]).cross(u).normalized();
        double brute = INFINITY;
        for (int i = -300; i <= 300; i++)
            for (int j = -300; j <= 300; j++) {
                const Eigen::Vector3d x = Eigen::Vector3d::Ones() + 0.01 * i * u + 0.01 * j * v;
                brute = std::min(brute, largest(G, x) / a.sum());
            }
        EXPECT_LE(g.ratio, brute * 1.005);
        best_gain = std::max(best_gain, g.equal_ratio / g.ratio);
    }
    EXPECT_GT(best_gain, 1.2); // the loud exciter is turned down: a real gain
}

TEST(ExciterGains, NothingToImproveOnGivesEqualGains)
{
    const Eigen::MatrixXf none(2, 0);
    Eigen::VectorXd a(2);
    a << 1.0, 2.0;
    EXPECT_EQ(pipeline::minimax_gains(none, a).gain, std::vector<double>({1.0, 1.0}));
    Eigen::MatrixXf G(2, 3);
    G << 1, 2, 3, 4, 5, 6;
    a << 1.0, -1.0; // the focus gets nothing from equal gains: no scale to hold
    EXPECT_EQ(pipeline::minimax_gains(G, a).gain, std::vector<double>({1.0, 1.0}));
}

// On the small plate: the calibration with minimax gains against the seed's
// equal gains, the same placement (fixed), every other option the same.
TEST(ExciterGains, CalibrationKeepsTheAmplitudeAndNeverLosesWholeAreaContrast)
{
    pipeline::CalibrationInput in = scene::calibration_input(scene_text::load("small.toml"), "small.toml");
    pipeline::CalibrationInput equal = in;
    equal.calibration.exciter_gains = pipeline::ExciterGainsMode::equal;
    const pipeline::CalibrationResult e = pipeline::calibrate(equal);
    in.exciters.placement = pipeline::PlacementMode::fixed;
    in.exciters.positions = e.exciters;
    const pipeline::CalibrationResult m = pipeline::calibrate(in);
    ASSERT_EQ(m.verification.foci.size(), e.verification.foci.size());
    double gained = 0;
    for (std::size_t f = 0; f < m.verification.foci.size(); f++) {
        const pipeline::FocusMetrics &a = m.verification.foci[f], &b = e.verification.foci[f];
        SCOPED_TRACE("focus " + std::to_string(a.id));
        EXPECT_NEAR(a.peak_m, in.pulse.amplitude_m, 0.01 * in.pulse.amplitude_m);
        ASSERT_TRUE(a.whole_area && b.whole_area);
        // Judged on the lattice's samples; the verdict refines between them.
        EXPECT_GE(a.whole_area_contrast_db, b.whole_area_contrast_db - 0.2);
        // And on the other foci beyond lambda/2 (the verdict's second criterion).
        EXPECT_LE(a.max_other_foci_m, b.max_other_foci_m * 1.001) << "other foci";
        gained = std::max(gained, a.whole_area_contrast_db - b.whole_area_contrast_db);
    }
    EXPECT_GT(gained, 0.5); // not vacuous: some focus gains

    // Weaker exciters: the equal design reaches the amplitude with 5 % to
    // spare at its weakest focus, less than the minimax gains would need.
    // The gains then move towards the minimax ones only as far as the force
    // allows: every focus still at the amplitude, none worse than equal gains.
    double weakest = INFINITY;
    for (double p : e.full_scale_peak_m)
        weakest = std::min(weakest, p);
    const double scale = 1.05 * in.pulse.amplitude_m / weakest;
    pipeline::CalibrationInput weak = in, weak_equal = equal;
    weak.exciters.force_full_scale_n *= scale;
    weak_equal.exciters.force_full_scale_n *= scale;
    weak_equal.exciters.placement = pipeline::PlacementMode::fixed;
    weak_equal.exciters.positions = e.exciters;
    const pipeline::CalibrationResult w = pipeline::calibrate(weak), we = pipeline::calibrate(weak_equal);
    double limited = 0;
    for (std::size_t f = 0; f < w.verification.foci.size(); f++) {
        const pipeline::FocusMetrics &a = w.verification.foci[f], &b = we.verification.foci[f];
        SCOPED_TRACE("weak exciters, focus " + std::to_string(a.id));
        EXPECT_NEAR(a.peak_m, in.pulse.amplitude_m, 0.01 * in.pulse.amplitude_m);
        EXPECT_GE(a.whole_area_contrast_db, b.whole_area_contrast_db - 0.2);
        // Not vacuous: the unconstrained gains would have reached further.
        limited = std::max(limited, m.verification.foci[f].whole_area_contrast_db - a.whole_area_contrast_db);
    }
    EXPECT_GT(limited, 0.3);
}
