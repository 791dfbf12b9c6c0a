// The robust inverse filter (stacked least squares over plates) on a small
// lossy plate: an ensemble of the nominal plate alone is the plain design
// sample for sample; two identical plates double G, b and lambda_max, so with
// the regularisation relative to lambda_max the design is the plain one to
// solver precision; the stacked design minimises the summed objective, so it
// scores strictly better on it than either single-plate design (evaluated by
// playback through each plate's H, not from the normal equations), and its
// loudest control point over both plates is below the louder single-plate
// design's; the margin level centres the threshold over the plates as for
// time reversal; the scene takes the combination and still refuses bad
// robust specs in one line.
#include "pipeline/calibrate.h"
#include "pipeline/design/inverse_filter.h"
#include "pipeline/data/lead_time.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/transfer/playback.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/verification/verification.h"
#include "scene/calibration_input.h"
#include "scene_text.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

using namespace calib;
using pipeline::Plates;
using pipeline::TransferMatrix;

namespace {

// A small lossy acrylic plate, four fixed exciters, 2 x 2 foci.
const std::string plate_scene = scene_text::load("inverse.toml");
const std::string inverse_scene =
    scene_text::replace(plate_scene, "verify_tail_s = 0.01\n", "verify_tail_s = 0.01\nmethod = \"inverse_filter\"\n");

pipeline::CalibrationInput input(const std::string &text) { return scene::calibration_input(text, "robust.toml"); }

// The problem inverse_filter_signals poses for focus f on H.
pipeline::InverseFilterProblem problem_of(const pipeline::CalibrationInput &in, const TransferMatrix &H, std::size_t f)
{
    pipeline::InverseFilterProblem p;
    p.drive_samples = static_cast<std::size_t>(std::floor(pipeline::target_lead_time_s(in) * H.rate_hz + 1e-9)) + 1;
    p.target = pipeline::focus_target(in, H.rate_hz, pipeline::focus_centre_s(in));
    p.foci = {H.exact_begin() + f};
    p.control = pipeline::control_points(in, H, f);
    return p;
}

double max_relative_difference(const std::vector<std::vector<double>> &a, const std::vector<std::vector<double>> &b)
{
    double diff = 0, top = 0;
    for (std::size_t c = 0; c < a.size(); c++)
        for (std::size_t j = 0; j < a[c].size(); j++) {
            diff = std::max(diff, std::abs(a[c][j] - b[c][j]));
            top = std::max(top, std::abs(a[c][j]));
        }
    return diff / top;
}

// What a design scores on the plates, from playback through each plate's H:
// the least-squares objective summed over the plates (focus error and every
// control point at all times) plus beta ||x||^2 (x: the drive in H's units,
// force / rate; no out-of-band term), and the worst control point's peak
// over the plates relative to the weakest plate's focal peak.
struct Score {
    double objective = 0;
    double worst_ratio = 0;
};
Score score(const Plates &plates, const pipeline::InverseFilterProblem &p, const std::vector<std::vector<double>> &s,
            double beta)
{
    std::vector<std::size_t> served = p.control;
    served.push_back(p.foci.front());
    const std::size_t Q = p.control.size(), out = p.drive_samples + plates.front()->samples - 1;
    Score r;
    double worst = 0, focal = std::numeric_limits<double>::infinity();
    for (const TransferMatrix *H : plates) {
        const pipeline::Playback pb(*H, served, p.drive_samples, out);
        const auto w = pb.field(s);
        for (std::size_t q = 0; q <= Q; q++)
            for (std::size_t n = 0; n < out; n++) {
                const double d = q == Q && n < p.target.size() ? p.target[n] : 0.0;
                r.objective += (double(w[q][n]) - d) * (double(w[q][n]) - d);
            }
        for (std::size_t q = 0; q < Q; q++)
            worst = std::max(worst, pipeline::sample_peak(w[q].data(), w[q].size()));
        focal = std::min(focal, pipeline::sample_peak(w[Q].data(), w[Q].size()));
    }
    const double rate = plates.front()->rate_hz;
    for (const auto &c : s)
        for (double v : c)
            r.objective += beta * (v / rate) * (v / rate);
    r.worst_ratio = worst / focal;
    return r;
}

} // namespace

TEST(RobustInverseFilter, AnEnsembleOfTheNominalPlateIsThePlainDesignSampleForSample)
{
    const pipeline::CalibrationResult plain = pipeline::calibrate(input(inverse_scene));
    const pipeline::CalibrationResult one = pipeline::calibrate(input(scene_text::replace(
        inverse_scene, "verify_tail_s = 0.01\n", "verify_tail_s = 0.01\nrobust = { E_scale = [1] }\n")));
    ASSERT_EQ(plain.signals.size(), 4u);
    ASSERT_EQ(one.signals.size(), 4u);
    for (std::size_t f = 0; f < plain.signals.size(); f++)
        EXPECT_EQ(plain.signals[f].samples, one.signals[f].samples) << "focus " << f;
    ASSERT_TRUE(one.tolerance && one.tolerance->nominal_design);
    EXPECT_TRUE(one.tolerance->ensemble.empty());
    EXPECT_EQ(one.tolerance->nominal_design->worst_whole_area_contrast_db,
              one.tolerance->nominal.worst_whole_area_contrast_db);
}

TEST(RobustInverseFilter, TwoIdenticalPlatesStackToThePlainDesign)
{
    const pipeline::CalibrationInput in = input(inverse_scene);
    const TransferMatrix H = pipeline::perturbed_transfer(in, in, in.exciters.positions, true);
    pipeline::InverseFilterOptions o;
    o.band_edge_hz = pipeline::pulse_max_frequency_hz(in.pulse);
    for (std::size_t f = 0; f < 2; f++) {
        const pipeline::InverseFilterProblem p = problem_of(in, H, f);
        ASSERT_GT(p.control.size(), 20u);
        o.minimax_iterations = 0;
        const pipeline::InverseFilterDesign one = pipeline::design_inverse_filter(H, p, o);
        const pipeline::InverseFilterDesign two = pipeline::design_inverse_filter(Plates{&H, &H}, p, o);
        EXPECT_NEAR(two.lambda_max / one.lambda_max, 2.0, 1e-9); // G doubles
        EXPECT_NEAR(two.beta / one.beta, 2.0, 1e-9);
        EXPECT_LT(max_relative_difference(one.drive, two.drive), 1e-9) << "focus " << f;
        // With the minimax refinement: every plate's |w| is the same, so the
        // weights and the chosen design are too.
        o.minimax_iterations = 3;
        const pipeline::InverseFilterDesign m1 = pipeline::minimax_design(H, p, o);
        const pipeline::InverseFilterDesign m2 = pipeline::minimax_design(Plates{&H, &H}, p, o);
        EXPECT_LT(max_relative_difference(m1.drive, m2.drive), 1e-6) << "focus " << f;
        EXPECT_GT(max_relative_difference(m1.drive, one.drive), 1e-3); // the refinement moved it
    }
}

TEST(RobustInverseFilter, StackedDesignIsNoWorseOverThePlatesThanEitherSinglePlateDesign)
{
    // A forced step keeps both plates at one rate; the member, at 0.6 of the
    // nominal loss factor, rings longer (a lower loss relaxes the bound).
    pipeline::CalibrationInput in = input(inverse_scene);
    char step[64];
    std::snprintf(step, sizeof step, "time_step_s = %.17g\n", 0.999 * in.plate->max_time_step());
    in = input(
        scene_text::replace(inverse_scene, "precision = \"double\"\n", std::string("precision = \"double\"\n") + step));
    const TransferMatrix H0 = pipeline::perturbed_transfer(in, in, in.exciters.positions, true);
    const pipeline::Perturbation member =
        pipeline::loss_case(in, 0.6 * pipeline::loss_factor(*in.plate, in.pulse.centre_hz), "ensemble");
    const TransferMatrix H1 =
        pipeline::perturbed_transfer(in, pipeline::perturbed_input(in, member), in.exciters.positions, true);
    ASSERT_EQ(H1.rate_hz, H0.rate_hz);
    ASSERT_EQ(H1.samples, H0.samples);
    const Plates both{&H0, &H1};

    pipeline::InverseFilterOptions o;
    o.minimax_iterations = 0; // the least-squares objective itself
    for (std::size_t f = 0; f < in.foci.points.size(); f++) {
        const pipeline::InverseFilterProblem p = problem_of(in, H0, f);
        const pipeline::InverseFilterDesign s = pipeline::design_inverse_filter(both, p, o);
        const pipeline::InverseFilterDesign d0 = pipeline::design_inverse_filter(H0, p, o);
        const pipeline::InverseFilterDesign d1 = pipeline::design_inverse_filter(H1, p, o);
        const Score ss = score(both, p, s.drive, s.beta), s0 = score(both, p, d0.drive, s.beta),
                    s1 = score(both, p, d1.drive, s.beta);
        // The stacked design is the minimiser of the summed objective; the
        // single-plate designs are not (a plate they ignore), by a margin well
        // above the playback's single-precision round-off (1e-7 here).
        EXPECT_LT(ss.objective, s0.objective * (1 - 1e-5)) << "focus " << f;
        EXPECT_LT(ss.objective, s1.objective * (1 - 1e-5)) << "focus " << f;
        // On both plates the stacked design's loudest control point is below
        // the louder of the single-plate designs' (the weakest focal peak over
        // the plates as reference).
        EXPECT_LT(ss.worst_ratio, std::max(s0.worst_ratio, s1.worst_ratio)) << "focus " << f;
    }
    // Mismatched plates are refused.
    TransferMatrix shorter = H1;
    shorter.samples -= 1;
    EXPECT_THROW(pipeline::design_inverse_filter(Plates{&H0, &shorter}, problem_of(in, H0, 0), o),
                 std::invalid_argument);
}

TEST(RobustInverseFilter, MarginLevelCentresTheThresholdOverThePlates)
{
    // Exciters strong enough that no level is capped at full scale; one
    // member plate, E x1.05 (rescaled from the nominal H).
    const pipeline::CalibrationInput in = input(scene_text::replace(
        scene_text::replace(inverse_scene, "force_full_scale_n = 0.5", "force_full_scale_n = 5"),
        "verify_tail_s = 0.01\n", "verify_tail_s = 0.01\nrobust = { E_scale = [1.05], level = \"margin\" }\n"));
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    std::vector<std::vector<int16_t>> table;
    for (const pipeline::DriveSignals &d : r.signals)
        table.push_back(d.samples);
    // The stored table replayed on both plates, each H simulated here: per
    // focus the weakest peak P and the strongest displacement elsewhere G
    // (other foci, the area beyond lambda/2) straddle the threshold T by the
    // same factor, P G = T^2 (to the 16-bit quantization of the level).
    pipeline::Perturbation member;
    member.youngs_scale = 1.05;
    std::vector<pipeline::Verification> v;
    for (const pipeline::Perturbation &p : {pipeline::Perturbation{}, member}) {
        const pipeline::CalibrationInput pin = pipeline::perturbed_input(in, p);
        const TransferMatrix H = pipeline::perturbed_transfer(in, pin, r.exciters, true);
        v.push_back(pipeline::verify_signals_with(pin, H, table, in.calibration.output_rate_hz));
    }
    const double T = in.calibration.threshold_m;
    const auto elsewhere = [](const pipeline::FocusMetrics &m) {
        return std::max(m.max_whole_area_m, m.max_other_foci_m);
    };
    for (std::size_t f = 0; f < table.size(); f++) {
        const double P = std::min(v[0].foci[f].peak_m, v[1].foci[f].peak_m);
        const double G = std::max(elsewhere(v[0].foci[f]), elsewhere(v[1].foci[f]));
        EXPECT_NEAR(P * G / (T * T), 1.0, 2e-3) << "focus " << f;
        EXPECT_GT(P, T) << "focus " << f; // the focus crosses, nothing else does, on both plates
        EXPECT_LT(G, T) << "focus " << f;
    }
}

TEST(RobustInverseFilter, SceneTakesTheCombinationAndRefusesBadSpecsInOneLine)
{
    const std::string with = scene_text::replace(inverse_scene, "verify_tail_s = 0.01\n",
                                                 "verify_tail_s = 0.01\nrobust = { loss = [0.030, 0.050], "
                                                 "E_scale = [0.97], level = \"margin\" }\n");
    EXPECT_EQ(scene_text::error_of(with), "");
    const pipeline::CalibrationInput in = input(with);
    ASSERT_TRUE(in.robust);
    EXPECT_EQ(in.calibration.method, pipeline::DriveMethod::inverse_filter);
    EXPECT_TRUE(in.robust->margin_level);
    EXPECT_NO_THROW(pipeline::check_feasible(in));

    auto bad = [&](const std::string &spec) {
        return scene_text::error_of(scene_text::replace(inverse_scene, "verify_tail_s = 0.01\n",
                                                        "verify_tail_s = 0.01\nrobust = " + spec + "\n"));
    };
    const std::string level = bad("{ E_scale = [0.97], level = \"worst\" }");
    EXPECT_EQ(level.rfind("scene.toml: calibration.robust.level: ", 0), 0u) << level;
    const std::string scale = bad("{ E_scale = [-0.97] }");
    EXPECT_EQ(scale.rfind("scene.toml: calibration.robust.E_scale", 0), 0u) << scale;
    const std::string empty = bad("{ level = \"margin\" }");
    EXPECT_EQ(empty.rfind("scene.toml: calibration.robust: names no ensemble", 0), 0u) << empty;
    const std::string key = bad("{ E_scales = [0.97] }");
    EXPECT_NE(key.find("calibration.robust.E_scales"), std::string::npos) << key;
    for (const std::string &e : {level, scale, empty, key})
        EXPECT_EQ(e.find('\n'), std::string::npos) << e;

    // What still cannot combine: a finger on the panel (no transfer matrix
    // holds, so there is no plate to stack), refused before any simulation.
    std::string refusal;
    try {
        pipeline::check_feasible(input(with + "[effects.finger]\nmass_kg = 0.004\nstiffness_n_m = 1500\n"
                                              "damping_n_s_m = 0.8\nposition_m = [0.15, 0.12]\n"));
    } catch (const std::invalid_argument &e) {
        refusal = e.what();
    }
    EXPECT_EQ(refusal.rfind("calibration.robust: ", 0), 0u) << refusal;
    EXPECT_NE(refusal.find("[effects.finger]"), std::string::npos) << refusal;
    EXPECT_EQ(refusal.find('\n'), std::string::npos) << refusal;
}
