// The tolerance box and the robust design on a small plate: a perturbation of
// zero reproduces the nominal verification bit for bit; E and rho scaled by
// the same s leave kappa (every Kirchhoff wave speed) unchanged and divide
// every displacement by s, so contrast and timing stay and peaks scale by 1/s
// (a simulated plate, checked against the nominal one; E alone must move
// them); impossible boxes are refused in one line naming the key; an
// ensemble of the nominal plate alone is the plain design; the table
// stretched by a panel's speed ratio gives the nominal field on simulated
// faster and slower plates, and the tolerance stage and the study report it.
#include "physics/dispersion.h"
#include "pipeline/calibrate.h"
#include "pipeline/robustness/tolerance.h"
#include "pipeline/verification/verification.h"
#include "pipeline/table_writer.h"
#include "pipeline/transfer/transfer.h"
#include "scene/calibration_input.h"
#include "study/robustness.h"
#include "scene_text.h"

#include <gtest/gtest.h>
#include <haptic_table.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

using namespace calib;
using pipeline::Perturbation;

namespace {

const std::string base_scene = scene_text::load("transfer.toml");

pipeline::CalibrationInput input(const std::string &text) { return scene::calibration_input(text, "robust.toml"); }

pipeline::StoredTable stored(const pipeline::CalibrationResult &r, const pipeline::CalibrationInput &in)
{
    pipeline::StoredTable t;
    for (const pipeline::DriveSignals &d : r.signals)
        t.signals.push_back(d.samples);
    t.rate_hz = in.calibration.output_rate_hz;
    return t;
}

// The verification of `table` on the plate of `p` (as evaluate_cases does).
pipeline::Verification verify_on(const pipeline::CalibrationInput &in, const pipeline::CalibrationResult &r,
                                 const Perturbation &p, pipeline::TransferMatrix *H_out = nullptr)
{
    const pipeline::CalibrationInput pin = pipeline::perturbed_input(in, p);
    pipeline::TransferMatrix H =
        pipeline::perturbed_transfer(in, pin, pipeline::moved_exciters(in, r.exciters, p), true);
    const pipeline::StoredTable t = stored(r, in);
    pipeline::Verification v = pipeline::verify_signals_with(pin, H, t.signals, t.rate_hz);
    if (H_out)
        *H_out = std::move(H);
    return v;
}

std::string first_line_of_refusal(const std::string &text)
{
    try {
        pipeline::check_feasible(input(text));
    } catch (const std::invalid_argument &e) {
        return e.what();
    }
    return "";
}

} // namespace

TEST(Robustness, ZeroPerturbationReproducesTheNominalVerificationExactly)
{
    const pipeline::CalibrationInput in = input(base_scene);
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    Perturbation zero;
    zero.name = "zero";
    zero.exciter_offsets_m.assign(r.exciters.size(), {0.0, 0.0});
    const pipeline::Verification v = verify_on(in, r, zero);
    ASSERT_EQ(v.foci.size(), r.verification.foci.size());
    for (std::size_t f = 0; f < v.foci.size(); f++) {
        const pipeline::FocusMetrics &a = v.foci[f], &b = r.verification.foci[f];
        EXPECT_EQ(a.peak_m, b.peak_m);
        EXPECT_EQ(a.lead_time_s, b.lead_time_s);
        EXPECT_EQ(a.max_other_foci_m, b.max_other_foci_m);
        EXPECT_EQ(a.whole_area_contrast_db, b.whole_area_contrast_db);
        EXPECT_EQ(a.max_whole_area_m, b.max_whole_area_m);
        EXPECT_EQ(a.perceived_offset_distance_m, b.perceived_offset_distance_m);
        EXPECT_EQ(a.spot_diameter_m, b.spot_diameter_m);
        EXPECT_EQ(a.crosses_threshold, b.crosses_threshold);
        EXPECT_EQ(a.others_below_threshold, b.others_below_threshold);
    }
    // The study's path gives the nominal figures too.
    const auto cases = pipeline::evaluate_cases(in, r.exciters, {zero}, stored(r, in), nullptr);
    const pipeline::CaseFigures nominal =
        pipeline::figures_of(r.verification, stored(r, in).signals, in.exciters.force_full_scale_n, 48000);
    EXPECT_EQ(cases.at(0).table.worst_whole_area_contrast_db, nominal.worst_whole_area_contrast_db);
    EXPECT_EQ(cases.at(0).table.min_peak_m, nominal.min_peak_m);
    EXPECT_EQ(cases.at(0).table.max_offset_m, nominal.max_offset_m);
    EXPECT_EQ(cases.at(0).table.foci_passing, nominal.foci_passing);
}

TEST(Robustness, SameScaleOfEAndRhoKeepsTheWavesAndDividesDisplacement)
{
    const pipeline::CalibrationInput in = input(base_scene);
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    const double s = 1.5;
    Perturbation both;
    both.youngs_scale = both.density_scale = s;
    pipeline::TransferMatrix Hs, H0;
    const pipeline::Verification vs = verify_on(in, r, both, &Hs);
    const pipeline::Verification v0 = verify_on(in, r, Perturbation{}, &H0);
    // kappa = sqrt(E d^2 / (12 (1 - nu^2) rho)) is unchanged: the same step, rate and H / s.
    EXPECT_NEAR(pipeline::perturbed_input(in, both).plate->kappa() / in.plate->kappa(), 1.0, 1e-15);
    ASSERT_EQ(Hs.data.size(), H0.data.size());
    EXPECT_EQ(Hs.rate_hz, H0.rate_hz);
    double peak = 0, err = 0;
    for (std::size_t i = 0; i < H0.data.size(); i++) {
        peak = std::max(peak, std::abs(double(H0.data[i])));
        err = std::max(err, std::abs(s * double(Hs.data[i]) - double(H0.data[i])));
    }
    EXPECT_LT(err, 1e-6 * peak); // float storage of a double simulation
    for (std::size_t f = 0; f < vs.foci.size(); f++) {
        const pipeline::FocusMetrics &a = vs.foci[f], &b = v0.foci[f];
        EXPECT_NEAR(s * a.peak_m / b.peak_m, 1.0, 1e-5) << "focus " << f;
        EXPECT_NEAR(s * a.max_whole_area_m / b.max_whole_area_m, 1.0, 1e-5);
        EXPECT_NEAR(a.lead_time_s, b.lead_time_s, 1e-7);
        EXPECT_NEAR(a.whole_area_contrast_db, b.whole_area_contrast_db, 1e-4);
        EXPECT_NEAR(a.other_foci_contrast_db, b.other_foci_contrast_db, 1e-4);
    }
    // E alone changes kappa: the responses are no longer a scaled copy.
    Perturbation stiff;
    stiff.youngs_scale = s;
    pipeline::TransferMatrix He;
    verify_on(in, r, stiff, &He);
    const std::size_t n = std::min(He.data.size(), H0.data.size());
    double diff = 0;
    for (std::size_t i = 0; i < n; i++)
        diff = std::max(diff, std::abs(double(He.data[i]) - double(H0.data[i])));
    EXPECT_GT(diff, 0.1 * peak);
}

TEST(Robustness, ImpossibleBoxesAreRefusedInOneLineNamingTheKey)
{
    const std::string thick = scene_text::error_of(std::string(base_scene) + "[tolerance]\nthickness_rel = 1.2\n");
    EXPECT_NE(thick.find("scene.toml: tolerance.thickness_rel:"), std::string::npos) << thick;
    EXPECT_NE(thick.find("-0.4 mm"), std::string::npos) << thick;
    EXPECT_EQ(thick.find('\n'), std::string::npos);
    const std::string loss = scene_text::error_of(std::string(base_scene) + "[tolerance]\nloss = [0.05, 0.01]\n");
    EXPECT_NE(loss.find("tolerance.loss:"), std::string::npos) << loss;
    const std::string unknown = scene_text::error_of(std::string(base_scene) + "[tolerance]\nE_relative = 0.1\n");
    EXPECT_NE(unknown.find("tolerance.E_relative"), std::string::npos) << unknown;

    // A forced step just inside the nominal plate's bound: tripling the loss breaks it.
    const pipeline::CalibrationInput in = input(base_scene);
    char step[64];
    std::snprintf(step, sizeof step, "time_step_s = %.17g\n", 0.999 * in.plate->max_time_step());
    std::string forced =
        scene_text::replace(base_scene, "precision = \"double\"\n", std::string("precision = \"double\"\n") + step);
    // (A loss range below the nominal 0.041 instead of acrylic's 0.030-0.050, which would break it first.)
    const std::string box = "[tolerance]\nloss = [0.030, 0.040]\n";
    EXPECT_EQ(first_line_of_refusal(forced + box + "loss_scale = [0.5]\n"), "");
    const std::string broken = first_line_of_refusal(forced + box + "loss_scale = [3]\n");
    EXPECT_EQ(broken.rfind("tolerance.loss_scale: loss x3: ", 0), 0u) << broken;
    EXPECT_NE(broken.find("breaks the explicit bound"), std::string::npos) << broken;
    EXPECT_EQ(broken.find('\n'), std::string::npos);
    // Without a forced step the lossier plate simply takes a shorter one.
    EXPECT_EQ(first_line_of_refusal(std::string(base_scene) + "[tolerance]\nloss_scale = [3]\n"), "");
}

TEST(Robustness, AnEnsembleOfOneIsTheNominalDesign)
{
    const std::string with_robust =
        scene_text::replace(base_scene, "verify_tail_s = 0.01\n", "verify_tail_s = 0.01\nrobust = { E_scale = [1] }\n");
    const pipeline::CalibrationResult plain = pipeline::calibrate(input(base_scene));
    const pipeline::CalibrationResult one = pipeline::calibrate(input(with_robust));
    ASSERT_EQ(plain.signals.size(), one.signals.size());
    for (std::size_t f = 0; f < plain.signals.size(); f++)
        EXPECT_EQ(plain.signals[f].samples, one.signals[f].samples) << "focus " << f;
    ASSERT_TRUE(one.tolerance && one.tolerance->nominal_design);
    EXPECT_TRUE(one.tolerance->ensemble.empty());
    EXPECT_EQ(one.tolerance->nominal_design->min_peak_m, one.tolerance->nominal.min_peak_m);

    // A member plate changes the design, and the run reports both over it.
    const std::string two = scene_text::replace(base_scene, "verify_tail_s = 0.01\n",
                                                "verify_tail_s = 0.01\nrobust = { E_scale = [1.1] }\n");
    const pipeline::CalibrationResult r2 = pipeline::calibrate(input(two));
    bool differs = false;
    for (std::size_t f = 0; f < plain.signals.size(); f++)
        differs = differs || plain.signals[f].samples != r2.signals[f].samples;
    EXPECT_TRUE(differs);
    ASSERT_TRUE(r2.tolerance);
    EXPECT_EQ(r2.tolerance->ensemble.size(), 1u);
    ASSERT_EQ(r2.tolerance->cases.size(), 1u); // without [tolerance]: over the ensemble
    EXPECT_TRUE(r2.tolerance->cases[0].nominal_design.has_value());
}

TEST(Robustness, ToleranceSectionParsesTheDocumentedKeys)
{
    const scene::Scene s =
        scene::parse_scene(std::string(base_scene) + "[tolerance]\nE_rel = 0.03\nrho_rel = 0.03\nthickness_rel = 0.05\n"
                                                     "loss = [0.030, 0.050]\nloss_scale = [0.5, 2]\n"
                                                     "exciter_position_m = 0.002\ntemperature_k = 10\n"
                                                     "speed_compensation = true\n",
                           "robust.toml");
    ASSERT_TRUE(s.tolerance);
    EXPECT_TRUE(s.tolerance->speed_compensation);
    EXPECT_EQ(s.tolerance->youngs_rel, 0.03);
    EXPECT_EQ(*s.tolerance->loss_max, 0.05);
    EXPECT_EQ(s.tolerance->loss_scale.size(), 2u);
    // Acrylic's dE/dT from the material library: +-10 K moves E by -+4 %.
    const pipeline::CalibrationInput in = input(std::string(base_scene) + "[tolerance]\ntemperature_k = 10\n");
    const std::vector<Perturbation> cases = pipeline::one_at_a_time(in, *in.tolerance);
    ASSERT_EQ(cases.size(), 4u); // the material's loss range (2) and the temperature (2)
    EXPECT_NEAR(cases[2].youngs_scale, 1.04, 1e-12);
    EXPECT_NEAR(cases[3].youngs_scale, 0.96, 1e-12);
    EXPECT_NEAR(pipeline::loss_factor(*pipeline::perturbed_input(in, cases[0]).plate, 1200), 0.030, 1e-12);
    // The calibration temperature the table stores (default 23 C), and the
    // bounds the table's panel section holds both to.
    EXPECT_EQ(in.plate_temperature_c, 23.0);
    const std::string warm =
        std::string(base_scene)
            .replace(base_scene.find("thickness_m = 0.002"), 19, "thickness_m = 0.002\ntemperature_c = 35.5");
    EXPECT_EQ(input(warm).plate_temperature_c, 35.5);
    auto refusal = [](const std::string &text) {
        try {
            input(text);
        } catch (const std::exception &e) {
            return std::string(e.what());
        }
        return std::string();
    };
    EXPECT_EQ(refusal(std::string(warm).replace(warm.find("35.5"), 4, "-150")),
              "robust.toml: plate.temperature_c: must lie in [-100, 300] degrees C, got -150");
    EXPECT_EQ(refusal(std::string(base_scene) + "[tolerance]\nE_per_k = 0.06\n"),
              "robust.toml: tolerance.E_per_k: must be a relative change of E per kelvin within +-0.05 (5 %/K), got "
              "0.06");
}

TEST(Robustness, MarginLevelCentresTheThresholdOverTheMemberPlates)
{
    // Exciters strong enough that no level is capped at full scale.
    const std::string text = scene_text::replace(
        scene_text::replace(base_scene, "force_full_scale_n = 0.5", "force_full_scale_n = 5"), "verify_tail_s = 0.01\n",
        "verify_tail_s = 0.01\nrobust = { E_scale = [1.05], level = \"margin\" }\n");
    const pipeline::CalibrationInput in = input(text);
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    // Replay the stored table on the nominal plate and the member (E x1.05):
    // per focus, the weakest peak P and the strongest displacement elsewhere G
    // (other foci, the area beyond lambda/2) straddle the threshold by the same
    // factor, P G = T^2 (to the 16-bit quantization of the level).
    Perturbation member;
    member.youngs_scale = 1.05;
    const pipeline::Verification v0 = verify_on(in, r, Perturbation{}), v1 = verify_on(in, r, member);
    const double T = in.calibration.threshold_m;
    for (std::size_t f = 0; f < v0.foci.size(); f++) {
        const auto G = [](const pipeline::FocusMetrics &m) { return std::max(m.max_whole_area_m, m.max_other_foci_m); };
        const double P = std::min(v0.foci[f].peak_m, v1.foci[f].peak_m);
        const double Gm = std::max(G(v0.foci[f]), G(v1.foci[f]));
        EXPECT_NEAR(P * Gm / (T * T), 1.0, 2e-3) << "focus " << f;
        EXPECT_NE(v0.foci[f].peak_m, in.pulse.amplitude_m); // not the scene's amplitude
    }
}

TEST(Robustness, EveryPlateIsJudgedOnTheScenesArea)
{
    // E x0.9: waves 2.6 % slower, lambda/2 at the pulse centre 2.6 % shorter
    // on that plate. The verification still judges every focus beyond the
    // scene's lambda/2 (the product's spatial criterion, in millimetres), so
    // a point in between is neither a ghost on the slow plate nor left out
    // on the fast one.
    const pipeline::CalibrationInput in = input(base_scene);
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    const double scene_half = physics::kirchhoff_wavelength_m(in.plate->kappa(), in.pulse.centre_hz) / 2;
    Perturbation soft;
    soft.youngs_scale = 0.9;
    const pipeline::CalibrationInput pin = pipeline::perturbed_input(in, soft);
    const double own_half = physics::kirchhoff_wavelength_m(pin.plate->kappa(), in.pulse.centre_hz) / 2;
    EXPECT_NEAR(own_half / scene_half, std::pow(0.9, 0.25), 1e-9); // not vacuous: the plate's own is shorter
    EXPECT_EQ(pipeline::judged_lambda_half_m(pin), scene_half);
    EXPECT_EQ(pipeline::judged_lambda_half_m(in), scene_half);
    const pipeline::Verification v = verify_on(in, r, soft);
    for (const pipeline::FocusMetrics &m : v.foci) {
        EXPECT_EQ(m.lambda_half_m, scene_half) << "focus " << m.id;
        ASSERT_TRUE(m.whole_area) << "focus " << m.id;
        EXPECT_GT(std::hypot(m.whole_area_max_at.x_m - m.at.x_m, m.whole_area_max_at.y_m - m.at.y_m), scene_half)
            << "focus " << m.id;
    }
}

TEST(Robustness, RescaledTransferAgreesWithASimulatedPlate)
{
    // Plates that differ only in kappa and mass per area: the nominal H
    // rescaled (the scheme at the step k / alpha) against a simulation of the
    // plate at its own step, a second method: the two differ only by the
    // scheme's time-discretisation error at the other step.
    const pipeline::CalibrationInput in = input(base_scene);
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    const pipeline::TransferMatrix H = pipeline::transfer_for(in, r.exciters);
    const pipeline::StoredTable t = stored(r, in);
    Perturbation thick, soft;
    thick.thickness_scale = 1.05;
    soft.youngs_scale = 0.97;
    soft.density_scale = 1.02;
    for (const Perturbation &p : {thick, soft}) {
        const pipeline::CalibrationInput pin = pipeline::perturbed_input(in, p);
        const auto Hr = pipeline::rescaled_transfer(in, pin, H, p);
        ASSERT_TRUE(Hr.has_value());
        EXPECT_NEAR(Hr->rate_hz / H.rate_hz, pin.plate->kappa() / in.plate->kappa(), 1e-12);
        const pipeline::Verification vr = pipeline::verify_signals_with(pin, *Hr, t.signals, t.rate_hz);
        const pipeline::Verification vs = verify_on(in, r, p);
        for (std::size_t f = 0; f < vr.foci.size(); f++) {
            EXPECT_NEAR(vr.foci[f].peak_m / vs.foci[f].peak_m, 1.0, 0.02) << "focus " << f;
            EXPECT_NEAR(vr.foci[f].lead_time_s, vs.foci[f].lead_time_s, 2e-4);
            EXPECT_NEAR(vr.foci[f].whole_area_contrast_db, vs.foci[f].whole_area_contrast_db, 0.3);
        }
    }
    // Another loss or moved exciters need a simulation.
    Perturbation lossy;
    lossy.loss_scale = 1.2;
    EXPECT_FALSE(pipeline::rescaled_transfer(in, pipeline::perturbed_input(in, lossy), H, lossy).has_value());
}

TEST(Robustness, SpeedCompensationPlaysTheNominalFieldOnAFasterOrSlowerPanel)
{
    // A panel whose kappa is alpha times the nominal plate's has
    // H'(t) = (m0 / m) / alpha * H(alpha t) (scale invariance of the plate
    // equation), so the table played alpha times faster gives the nominal
    // field alpha times sooner, with every displacement times
    // (m0 / m) / alpha^2: the same contrast and the same verdicts. Checked on
    // plates simulated at their own parameters (a second method: not the
    // rescaled nominal H), with the table stretched as the device does it.
    const pipeline::CalibrationInput in = input(base_scene);
    const pipeline::CalibrationResult r = pipeline::calibrate(in);
    const pipeline::StoredTable t = stored(r, in);
    Perturbation soft, thick;
    soft.youngs_scale = 0.92;
    thick.thickness_scale = 1.06;
    for (const Perturbation &p : {soft, thick}) {
        const pipeline::CalibrationInput pin = pipeline::perturbed_input(in, p);
        const double alpha = pin.plate->kappa() / in.plate->kappa();
        const double mass = p.density_scale * p.thickness_scale; // m / m0
        const pipeline::TransferMatrix H = pipeline::perturbed_transfer(in, pin, r.exciters, true);
        const auto s = pipeline::stretched(t.signals, r.exciters.size(), alpha);
        const pipeline::Verification plain = pipeline::verify_signals_with(pin, H, t.signals, t.rate_hz);
        const pipeline::Verification comp = pipeline::verify_signals_with(pin, H, s, t.rate_hz);
        double lost = 0;
        for (std::size_t f = 0; f < comp.foci.size(); f++) {
            const pipeline::FocusMetrics &c = comp.foci[f], &n = r.verification.foci[f];
            // Seen: 1e-4 and 0.001 dB (the plates keep the nominal step, so
            // the scheme's error differs a little; the stretch adds its own).
            EXPECT_NEAR(c.peak_m / (n.peak_m / (mass * alpha * alpha)), 1.0, 1e-3) << "alpha " << alpha << " " << f;
            EXPECT_NEAR(c.lead_time_s, n.lead_time_s / alpha, 2e-4);
            EXPECT_NEAR(c.whole_area_contrast_db, n.whole_area_contrast_db, 0.02);
            lost = std::max(lost, std::abs(n.whole_area_contrast_db - plain.foci[f].whole_area_contrast_db));
        }
        // Not vacuous: uncompensated, the contrast moves by 0.7-1.3 dB.
        EXPECT_GT(lost, 0.5) << "alpha " << alpha;
    }
    // Through the tolerance stage: the plates whose speed differs get the
    // compensated figures, the others (loss) none; a box beyond what a device
    // stretches is refused in one line naming the key.
    pipeline::CalibrationInput c = input(base_scene + "\n[tolerance]\nE_rel = 0.03\nloss_scale = [1.5]\n"
                                                      "speed_compensation = true\n");
    const auto cases =
        pipeline::evaluate_cases(c, r.exciters, pipeline::one_at_a_time(c, *c.tolerance), t, nullptr, {}, nullptr);
    ASSERT_EQ(cases.size(), 5u); // E +-3 %, acrylic's loss range, loss x1.5
    for (const pipeline::ToleranceCase &k : cases) {
        EXPECT_EQ(k.compensated.has_value(), k.perturbation.factor == "E") << k.perturbation.name;
        if (k.compensated) {
            EXPECT_NEAR(k.compensated->worst_whole_area_contrast_db,
                        pipeline::figures_of(r.verification, t.signals, 0.5, 48000).worst_whole_area_contrast_db, 0.02);
        }
    }
    EXPECT_EQ(first_line_of_refusal(base_scene + "\n[tolerance]\nthickness_rel = 0.3\nspeed_compensation = true\n"),
              "tolerance.speed_compensation: d -30 % makes the response run 0.700 times as fast, beyond what a device "
              "stretches (0.8-1.25)");
    try {
        input(base_scene + "\n[tolerance]\nspeed_compensation = 1\n");
        ADD_FAILURE() << "a number for a flag was taken";
    } catch (const std::exception &e) {
        EXPECT_STREQ(e.what(), "robust.toml: tolerance.speed_compensation: must be true or false");
    }
}

TEST(Robustness, TheStudyReportsThePlatesAsTheDeviceCompensatesThem)
{
    // calibgen study robustness on a box with speed compensation: the CSV
    // gives each plate its speed ratio and, where it is not 1, the figures of
    // the stretched table; those equal the nominal plate's (the compensation
    // is exact on a plate that differs only in kappa and mass), and the
    // summary names the worst case compensated.
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "robustness-study-compensated";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string scene = (dir / "box.toml").string();
    {
        std::ofstream f(scene);
        f << base_scene
          << "\n[tolerance]\nE_rel = 0.03\nthickness_rel = 0.05\nloss_scale = [1.5]\n"
             "speed_compensation = true\n";
    }
    study::RobustnessOptions o;
    o.scene_path = scene;
    o.report_dir = (dir / "r").string();
    o.random_cases = 0;
    o.quiet = true;
    const study::RobustnessResult r = study::run_robustness_study(o);
    const std::string md = study::write_robustness_report(r, o.report_dir);
    std::ifstream csv(dir / "r" / "robustness.csv");
    std::string header, line;
    ASSERT_TRUE(std::getline(csv, header));
    auto column = [&](const std::string &name) {
        std::istringstream h(header);
        int i = 0;
        for (std::string c; std::getline(h, c, ','); i++)
            if (c == name)
                return i;
        return -1;
    };
    const int ratio = column("speed_ratio"), comp = column("compensated_worst_whole_area_contrast_db"),
              contrast = column("worst_whole_area_contrast_db");
    ASSERT_GE(ratio, 0);
    ASSERT_GE(comp, 0);
    std::vector<std::vector<std::string>> rows;
    while (std::getline(csv, line)) {
        std::vector<std::string> cells;
        std::istringstream l(line);
        for (std::string c; std::getline(l, c, ',');)
            cells.push_back(c);
        rows.push_back(cells);
    }
    // nominal, E -+3 %, d -+5 %, acrylic's loss range (2), loss x1.5
    ASSERT_EQ(rows.size(), 8u);
    const double nominal = std::stod(rows[0][std::size_t(contrast)]);
    int compensated = 0;
    for (const auto &row : rows) {
        const double alpha = std::stod(row[std::size_t(ratio)]);
        if (alpha == 1.0) {
            EXPECT_TRUE(row[std::size_t(comp)].empty()) << row[0];
            continue;
        }
        compensated++;
        EXPECT_NEAR(std::stod(row[std::size_t(comp)]), nominal, 0.02) << row[0];
        EXPECT_GT(std::abs(std::stod(row[std::size_t(contrast)]) - nominal), 0.05) << row[0]; // not vacuous
    }
    EXPECT_EQ(compensated, 4);
    EXPECT_NE(md.find("worst over the box, speed compensated"), std::string::npos);
    EXPECT_NE(md.find("E -3 %, compensated x0.9849"), std::string::npos);
    std::filesystem::remove_all(dir);
}

TEST(Robustness, ATableStatesItsPanelOnlyWhenItsDEdTIsKnown)
{
    // A library material: its dE/E/dT and the calibration temperature; a
    // custom material has none, so no panel section (a device must not take
    // 0 for it), unless the scene states E_per_k.
    const std::string acrylic = "material = \"acrylic\"";
    const std::string custom =
        std::string(base_scene)
            .replace(base_scene.find(acrylic), acrylic.size(),
                     "material = { name = \"pc\", density_kg_m3 = 1200, youngs_pa = 2.4e9, poisson = 0.37 }");
    const std::string path = (std::filesystem::temp_directory_path() / "robust-panel.htab").string();
    auto panel_of = [&](const std::string &text, haptic_panel *p) {
        const pipeline::CalibrationInput in = input(text);
        pipeline::write_table(path, in, pipeline::calibrate(in));
        haptic_table t{};
        haptic_table_error err{};
        EXPECT_EQ(haptic_table_open(path.c_str(), &t, &err), 0) << err.message;
        const int rc = haptic_table_panel(&t, p);
        haptic_table_close(&t);
        std::filesystem::remove(path);
        return rc;
    };
    haptic_panel p{};
    ASSERT_EQ(
        panel_of(std::string(base_scene)
                     .replace(base_scene.find("thickness_m = 0.002"), 19, "thickness_m = 0.002\ntemperature_c = 31"),
                 &p),
        0);
    EXPECT_EQ(p.temperature_c, 31.0);
    EXPECT_EQ(p.youngs_per_k, -4e-3); // acrylic's, from the material library
    EXPECT_EQ(panel_of(custom, &p), -1);
    ASSERT_EQ(panel_of(custom + "\n[tolerance]\nE_per_k = 0\n", &p), 0);
    EXPECT_EQ(p.youngs_per_k, 0.0);
    EXPECT_EQ(p.temperature_c, 23.0);
}
