// The inverse filter's shared design (each point's cross-correlations computed
// once for all foci and minimax passes, the regularised system solved by block
// Levinson, the foci designed in parallel) against the reference that designs
// each focus from scratch (minimax_design: G formed from the summed spectra,
// Cholesky): the same drives to round-off on a small plate, for one plate and
// stacked over two, and the signals stage's progress counted per focus.
//
// The bound: the two sum the same products in another order and solve by
// another backward-stable method, a relative difference of ~1e-16 in G and b
// amplified by the regularised system's condition number (about
// 1 / regularization = 1e4) to ~1e-12 in a design (5e-15 measured here). The
// minimax passes weigh the control points by their peaks played in single
// precision (pipeline/transfer/playback.h), where a sample on the other side of a float's
// rounding moves a weight by ~6e-8 relative; 1e-9 leaves room for that on
// this plate, and an error that is not round-off (one control point left
// out) shows at 3e-3 or more.
#include "pipeline/calibrate.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/design/levinson_kernels.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/verification/verification.h"
#include "pipeline/transfer/transfer.h"
#include "scene/calibration_input.h"
#include "scene_text.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

using namespace calib;
using pipeline::Plates;
using pipeline::TransferMatrix;

namespace {

// A small lossy acrylic plate, four fixed exciters, 2 x 2 foci.
const std::string inverse_scene = scene_text::replace(scene_text::load("inverse.toml"), "verify_tail_s = 0.01\n",
                                                      "verify_tail_s = 0.01\nmethod = \"inverse_filter\"\n");

pipeline::CalibrationInput input(const std::string &text) { return scene::calibration_input(text, "shared.toml"); }

// Largest difference of two designs' drives relative to the largest drive sample.
double max_relative_difference(const pipeline::InverseFilterDesign &a, const pipeline::InverseFilterDesign &b)
{
    EXPECT_EQ(a.drive.size(), b.drive.size());
    double diff = 0, top = 0;
    for (std::size_t c = 0; c < std::min(a.drive.size(), b.drive.size()); c++) {
        EXPECT_EQ(a.drive[c].size(), b.drive[c].size());
        for (std::size_t j = 0; j < std::min(a.drive[c].size(), b.drive[c].size()); j++) {
            diff = std::max(diff, std::abs(a.drive[c][j] - b.drive[c][j]));
            top = std::max(top, std::abs(a.drive[c][j]));
        }
    }
    return diff / top;
}

} // namespace

TEST(InverseFilterShared, TheSharedDesignsAreThePerFocusDesignsToRoundOff)
{
    const pipeline::CalibrationInput in = input(inverse_scene);
    const TransferMatrix H = pipeline::transfer_for(in, in.exciters.positions);
    std::size_t calls = 0, last_done = 0, last_total = 0;
    const pipeline::ProgressFn progress = [&](const std::string &stage, std::size_t done, std::size_t total) {
        EXPECT_EQ(stage, "signals");
        EXPECT_GE(done, last_done);
        calls++;
        last_done = done;
        last_total = total;
    };
    const auto shared = pipeline::inverse_filter_designs(in, Plates{&H}, progress, true);
    const auto reference = pipeline::inverse_filter_designs(in, Plates{&H}, {}, false);
    ASSERT_EQ(shared.size(), 4u);
    ASSERT_EQ(reference.size(), 4u);
    for (std::size_t f = 0; f < shared.size(); f++) {
        EXPECT_NEAR(shared[f].beta, reference[f].beta, 1e-9 * reference[f].beta) << "focus " << f;
        EXPECT_LT(max_relative_difference(shared[f], reference[f]), 1e-9) << "focus " << f;
    }
    // Once at the start, once per focus.
    EXPECT_EQ(calls, 5u);
    EXPECT_EQ(last_done, 4u);
    EXPECT_EQ(last_total, 4u);

    // Stacked over the nominal plate and a lossier one, on the same time step
    // (the plates' H at the same rate and length).
    char step[64];
    std::snprintf(step, sizeof step, "time_step_s = %.17g\n", 0.999 * in.plate->max_time_step());
    const pipeline::CalibrationInput fixed = input(
        scene_text::replace(inverse_scene, "precision = \"double\"\n", std::string("precision = \"double\"\n") + step));
    const TransferMatrix H0 = pipeline::perturbed_transfer(fixed, fixed, fixed.exciters.positions, true);
    const pipeline::Perturbation member =
        pipeline::loss_case(fixed, 0.6 * pipeline::loss_factor(*fixed.plate, fixed.pulse.centre_hz), "ensemble");
    const TransferMatrix H1 =
        pipeline::perturbed_transfer(fixed, pipeline::perturbed_input(fixed, member), fixed.exciters.positions, true);
    const auto plain = pipeline::inverse_filter_designs(fixed, Plates{&H0}, {}, true);
    const auto shared2 = pipeline::inverse_filter_designs(fixed, Plates{&H0, &H1}, {}, true);
    const auto reference2 = pipeline::inverse_filter_designs(fixed, Plates{&H0, &H1}, {}, false);
    ASSERT_EQ(shared2.size(), 4u);
    for (std::size_t f = 0; f < shared2.size(); f++) {
        EXPECT_LT(max_relative_difference(shared2[f], reference2[f]), 1e-9) << "focus " << f;
        // Not the plain design: the second plate counts.
        EXPECT_GT(max_relative_difference(shared2[f], plain[f]), 1e-3) << "focus " << f;
    }
}

// Block Levinson's products (levinson_kernels.h) against Eigen's: the 8-channel
// shape with its register paths (rows not a multiple of 8 included) and a
// generic one, with leading dimensions beyond the blocks as the recursion has.
TEST(LevinsonKernels, ProductsEqualEigensToRoundOff)
{
    for (int c : {8, 3})
        for (Eigen::Index m : {Eigen::Index(1), Eigen::Index(13), Eigen::Index(64), Eigen::Index(203)}) {
            SCOPED_TRACE("c " + std::to_string(c) + ", m " + std::to_string(m));
            const Eigen::Index ld = m + 5;
            const Eigen::MatrixXd A = Eigen::MatrixXd::Random(c, m), B = Eigen::MatrixXd::Random(ld, c);
            Eigen::MatrixXd out(c, c);
            pipeline::levinson_product(A.data(), c, B.data(), ld, m, c, out.data());
            const Eigen::MatrixXd want = A * B.topRows(m);
            EXPECT_LE((out - want).cwiseAbs().maxCoeff(), 1e-13 * double(m));

            const Eigen::MatrixXd X = Eigen::MatrixXd::Random(ld, c), S = Eigen::MatrixXd::Random(c, c);
            Eigen::MatrixXd Y = Eigen::MatrixXd::Random(ld, c);
            const Eigen::MatrixXd before = Y;
            pipeline::levinson_update(Y.data() + 2, X.data() + 1, ld, m, c, S.data());
            Eigen::MatrixXd expect = before;
            expect.middleRows(2, m) += X.middleRows(1, m) * S;
            EXPECT_LE((Y - expect).cwiseAbs().maxCoeff(), 1e-13);
        }
}
