// The inverse filter against independent truth: the multiple-input/output
// inverse theorem (Miyoshi & Kaneda 1988: with Q < C outputs and drives of
// J >= Q (S - 1) / (C - Q) samples an exact FIR inverse exists, so the
// unregularised least squares reproduces the target to solver precision),
// Tikhonov's monotonicity (the residual grows and the drive norm shrinks with
// the weight), the large-weight limit (the matched filter A^T d, time reversal
// up to scale), Cauchy-Schwarz (the matched filter maximises the focus's
// correlation with the pulse per root drive energy); the lead time honoured
// by both methods, the drive energy of a hand-computed signal, and the
// refusal of bad input naming its key.
#include "pipeline/calibrate.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/drive_figures.h"
#include "pipeline/inverse_filter.h"
#include "pipeline/lead_time.h"
#include "pipeline/multitouch.h"
#include "pipeline/playback.h"
#include "pipeline/radiation.h"
#include "pipeline/verification.h"
#include "scene/calibration_input.h"
#include "scene/toml_fields.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "scene_text.h"

using namespace calib;

namespace {

using scene_text::replace;

// A small lossy acrylic plate, four fixed exciters, 2 x 2 foci.
const std::string plate_scene = scene_text::load("inverse.toml");

std::vector<pipeline::Point> foci_of(const pipeline::CalibrationInput &in)
{
    std::vector<pipeline::Point> p;
    for (const auto &f : in.foci.points)
        p.push_back(f.at);
    return p;
}

// H of the four exciters at the foci only, S samples at the calibration's rate.
pipeline::TransferMatrix short_transfer(const pipeline::CalibrationInput &in, std::size_t samples)
{
    engine::Simulation probe(in.plate, pipeline::single_core_options(in));
    pipeline::TransferOptions o = pipeline::transfer_options(in, probe.time_step_s());
    o.samples = samples;
    o.lattice_stride = 0;
    return pipeline::simulate_transfer(in, in.exciters.positions, foci_of(in), o);
}

// Playback by direct convolution (double): w_p[n] = (1/R) sum_c sum_j s_c[j] h_cp[n - j].
std::vector<double> play(const pipeline::TransferMatrix &H, const std::vector<std::vector<double>> &s, std::size_t p,
                         std::size_t out)
{
    std::vector<double> w(out, 0.0);
    for (std::size_t c = 0; c < H.channels; c++) {
        const float *h = H.response(c, p);
        for (std::size_t n = 0; n < out; n++)
            for (std::size_t j = 0; j < s[c].size() && j <= n; j++)
                if (n - j < H.samples)
                    w[n] += s[c][j] * double(h[n - j]) / H.rate_hz;
    }
    return w;
}

struct Residual {
    double relative = 0;      // || A s - d || / || d || over the foci and control rows
    double drive_norm = 0;    // || s ||
    double correlation = 0;   // sum over the foci of <w_f, d> / || s ||
};

Residual residual_of(const pipeline::TransferMatrix &H, const pipeline::InverseFilterProblem &p,
                     const std::vector<std::vector<double>> &s)
{
    const std::size_t out = p.drive_samples + H.samples - 1;
    Residual r;
    double err = 0, dd = 0;
    for (std::size_t f : p.foci) {
        const std::vector<double> wf = play(H, s, f, out);
        for (std::size_t n = 0; n < out; n++) {
            const double d = n < p.target.size() ? p.target[n] : 0.0;
            err += (wf[n] - d) * (wf[n] - d);
            dd += d * d;
            r.correlation += wf[n] * d;
        }
    }
    for (std::size_t q : p.control)
        for (double v : play(H, s, q, out))
            err += v * v;
    for (const auto &c : s)
        for (double v : c)
            r.drive_norm += v * v;
    r.drive_norm = std::sqrt(r.drive_norm);
    r.relative = std::sqrt(err / dd);
    r.correlation /= r.drive_norm;
    return r;
}

// max over lags of the normalised cross-correlation of two multichannel drives
// ([n][c], the same channel count), lags within +-max_lag frames.
double best_correlation(const std::vector<double> &a, const std::vector<double> &b, unsigned C, long max_lag)
{
    const long na = long(a.size() / C), nb = long(b.size() / C);
    double aa = 0, bb = 0;
    for (double v : a)
        aa += v * v;
    for (double v : b)
        bb += v * v;
    double best = 0;
    for (long lag = -max_lag; lag <= max_lag; lag++) {
        double ab = 0;
        for (long n = 0; n < na; n++) {
            const long m = n + lag;
            if (m < 0 || m >= nb)
                continue;
            for (unsigned c = 0; c < C; c++)
                ab += a[std::size_t(n) * C + c] * b[std::size_t(m) * C + c];
        }
        best = std::max(best, std::abs(ab) / std::sqrt(aa * bb));
    }
    return best;
}

}  // namespace

TEST(InverseFilter, UnregularisedInverseIsExactWithFewerPointsThanExcitersAndLongEnoughDrives)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    const std::size_t S = 48, C = 4;
    const pipeline::TransferMatrix H = short_transfer(in, S);
    ASSERT_EQ(H.channels, C);
    pipeline::InverseFilterOptions o;
    o.regularization = 0;
    for (std::size_t Q : {2u, 3u}) {  // the focus and Q - 1 control points
        pipeline::InverseFilterProblem p;
        p.foci = {0};
        for (std::size_t q = 1; q < Q; q++)
            p.control.push_back(q);
        p.drive_samples = (Q * (S - 1) + (C - Q) - 1) / (C - Q) + 1;  // the MINT length, rounded up
        p.target = pipeline::focus_target(in, H.rate_hz, double(p.drive_samples) / H.rate_hz);
        const pipeline::InverseFilterDesign d = pipeline::design_inverse_filter(H, p, o);
        const Residual r = residual_of(H, p, d.drive);
        EXPECT_LT(r.relative, 1e-6) << Q << " points, J = " << p.drive_samples;
        // Not vacuous: below the theorem's length the system is overdetermined and no drive is exact.
        p.drive_samples = 8;
        p.target = pipeline::focus_target(in, H.rate_hz, 8.0 / H.rate_hz);
        EXPECT_GT(residual_of(H, p, pipeline::design_inverse_filter(H, p, o).drive).relative, 1e-2) << Q << " points";
    }
}

TEST(InverseFilter, RegularisationTradesResidualForDriveAndTendsToTheMatchedFilter)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    const pipeline::TransferMatrix H = short_transfer(in, 96);
    pipeline::InverseFilterProblem p;
    p.foci = {0};
    p.control = {1, 2, 3};
    p.drive_samples = 40;  // far below the exact length: a true trade
    p.target = pipeline::focus_target(in, H.rate_hz, 36.0 / H.rate_hz);
    pipeline::InverseFilterOptions o;  // plain Tikhonov: no out-of-band weighting
    std::vector<Residual> r;
    std::vector<std::vector<std::vector<double>>> drives;
    const double eps[] = {1e-9, 1e-6, 1e-4, 1e-2, 1, 1e2, 1e8};
    for (double e : eps) {
        o.regularization = e;
        drives.push_back(pipeline::design_inverse_filter(H, p, o).drive);
        r.push_back(residual_of(H, p, drives.back()));
    }
    for (std::size_t i = 1; i < r.size(); i++) {
        EXPECT_GE(r[i].relative, r[i - 1].relative * (1 - 1e-9)) << "eps " << eps[i];
        EXPECT_LE(r[i].drive_norm, r[i - 1].drive_norm * (1 + 1e-6)) << "eps " << eps[i];
        // Cauchy-Schwarz: the matched filter maximises <w_f, d> / ||s||, and the
        // Tikhonov path approaches it monotonically.
        EXPECT_GE(r[i].correlation, r[i - 1].correlation * (1 - 1e-6)) << "eps " << eps[i];
    }
    EXPECT_GT(r.back().correlation, 1.5 * r.front().correlation);
    EXPECT_GT(r.front().relative, 0);
    EXPECT_LT(r.front().relative, 0.8 * r.back().relative);

    // The large-weight limit: s -> A_f^T d / beta, the matched filter, by a direct loop.
    std::vector<double> mf, big;
    for (std::size_t c = 0; c < H.channels; c++) {
        const float *h = H.response(c, p.foci.front());
        for (std::size_t j = 0; j < p.drive_samples; j++) {
            double acc = 0;
            for (std::size_t m = 0; m < H.samples && m + j < p.target.size(); m++)
                acc += double(h[m]) * p.target[m + j];
            mf.push_back(acc);
            big.push_back(drives.back()[c][j]);
        }
    }
    EXPECT_GT(best_correlation(mf, big, 1, 0), 1 - 1e-6);
    // The out-of-band weighting hardly moves that limit: A^T d lies in the pulse's band
    // but for H's own content above it (measured 0.991).
    o.band_edge_hz = pipeline::pulse_max_frequency_hz(in.pulse);
    o.regularization = 1e8;
    const auto oob = pipeline::design_inverse_filter(H, p, o).drive;
    std::vector<double> flat;
    for (const auto &c : oob)
        flat.insert(flat.end(), c.begin(), c.end());
    EXPECT_GT(best_correlation(mf, flat, 1, 0), 0.98);
}

TEST(InverseFilter, BothMethodsMeetTheLeadTimeAndTheLargeWeightLimitIsTimeReversal)
{
    pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    in.calibration.dither = false;
    in.calibration.lead_time_s = 0.006;
    const pipeline::TransferMatrix H = pipeline::transfer_for(in, in.exciters.positions);
    const double period = 1 / in.pulse.centre_hz;

    pipeline::CalibrationResult tr, inv;
    tr.exciters = inv.exciters = in.exciters.positions;
    pipeline::signals_and_verification(in, H, {}, tr);
    in.calibration.method = pipeline::DriveMethod::inverse_filter;
    pipeline::signals_and_verification(in, H, {}, inv);
    double tr_worst = INFINITY, inv_worst = INFINITY;
    for (std::size_t f = 0; f < in.foci.points.size(); f++) {
        for (const pipeline::CalibrationResult *r : {&tr, &inv}) {
            const pipeline::FocusMetrics &m = r->verification.foci[f];
            // The focal peak at the lead time, never later than a tenth of a period.
            EXPECT_LE(m.lead_time_s, 0.006 + 0.1 * period) << "focus " << m.id;
            EXPECT_GT(m.lead_time_s, 0.006 - 0.5 * period) << "focus " << m.id;
            EXPECT_TRUE(m.crosses_threshold) << "focus " << m.id;
        }
        // The inverse filter's drive is no longer than the lead time.
        EXPECT_LE(double(inv.signals[f].frames) / in.calibration.output_rate_hz, 0.006 + 2 / H.rate_hz);
        tr_worst = std::min(tr_worst, tr.verification.foci[f].whole_area_contrast_db);
        inv_worst = std::min(inv_worst, inv.verification.foci[f].whole_area_contrast_db);
    }
    // What the inverse filter is for: more contrast over the whole area than time reversal.
    EXPECT_GT(inv_worst, tr_worst + 1.0);

    // Each focus's sound in the verification (the Rayleigh integral of each
    // exciter's lattice responses, formed once) against a second route: the
    // focus's field played over the whole lattice, then the Rayleigh integral
    // point by point (rayleigh_pressure, checked against a piston below).
    for (const pipeline::CalibrationResult *r : {&tr, &inv})
        for (std::size_t f = 0; f < in.foci.points.size(); f++) {
            const pipeline::FocusMetrics &m = r->verification.foci[f];
            ASSERT_TRUE(m.sound) << "focus " << m.id;
            const auto force = pipeline::drive_forces(in, H, pipeline::to_unit(r->signals[f].samples),
                                                      unsigned(H.channels), in.calibration.output_rate_hz);
            const std::size_t drive = force[0].size();
            const std::size_t samples = drive + std::size_t(std::ceil(in.calibration.verify_tail_s * H.rate_hz));
            std::vector<std::size_t> all(H.lattice.size());
            for (std::size_t n = 0; n < all.size(); n++)
                all[n] = n;
            const pipeline::Playback pb(H, all, drive, samples);
            const auto &pp = in.plate->params();
            const std::vector<double> p = pipeline::rayleigh_pressure(
                H.lattice, pb.field(force), H.rate_hz, {pp.size_x_m / 2, pp.size_y_m / 2}, 0.5, pb.output_samples());
            const double second = 10 * std::log10(pipeline::a_weighted_exposure(p, H.rate_hz) / (20e-6 * 20e-6));
            EXPECT_NEAR(m.sound_exposure_dba, second, 0.1) << "focus " << m.id;
            EXPECT_GT(m.sound_exposure_dba, 0.0) << "focus " << m.id;
        }

    // A very large weight gives time reversal's drive up to scale (and the
    // pulse's sign: time reversal returns it reversed), to within the tapers
    // and the half pulse time reversal keeps after the focus instant.
    in.calibration.regularization = 1e8;
    const auto limit = pipeline::inverse_filter_signals(in, H);
    in.calibration.method = pipeline::DriveMethod::time_reversal;
    const auto trs = pipeline::signals_from_transfer(in, H);
    for (std::size_t f = 0; f < limit.size(); f++)
        EXPECT_GT(best_correlation(limit[f].normalized, trs[f].normalized, limit[f].channels, 48), 0.97) << f;
}

TEST(InverseFilter, DriveEnergyAndOutOfBandFractionOfHandComputedSignals)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    const double rate = 48000, edge = pipeline::pulse_max_frequency_hz(in.pulse);
    const unsigned C = 2;
    const std::size_t n = 4800;  // 0.1 s: whole periods of both tones below
    // Channel 0: 1200 Hz (in band) at 10000 counts; channel 1: silent, then a tone above the band.
    const double f_hi = 480 * std::ceil(1.5 * edge / 480);
    std::vector<int16_t> s(n * C, 0);
    for (std::size_t i = 0; i < n; i++) {
        s[i * C] = static_cast<int16_t>(std::lround(10000 * std::sin(2 * std::numbers::pi * 1200 * double(i) / rate)));
        s[i * C + 1] = static_cast<int16_t>(std::lround(5000 * std::sin(2 * std::numbers::pi * f_hi * double(i) / rate)));
    }
    const pipeline::DriveFigures d = pipeline::drive_figures(in, s, C, rate, 2e-6);
    const double F = 0.5 / 32767;  // N per count
    const double e0 = 0.5 * (10000 * F) * (10000 * F) * 0.1, e1 = 0.5 * (5000 * F) * (5000 * F) * 0.1;
    EXPECT_NEAR(d.energy_n2s, e0 + e1, 1e-3 * (e0 + e1));  // rounding to counts only
    EXPECT_NEAR(d.out_of_band_fraction, e1 / (e0 + e1), 1e-3);
    EXPECT_NEAR(d.peak_per_root_energy, 2e-6 / std::sqrt(e0 + e1), 1e-3 * 2e-6 / std::sqrt(e0 + e1));
}

TEST(InverseFilter, BadInputIsRefusedNamingTheKey)
{
    auto scene_error = [](const std::string &text) {
        try {
            (void)scene::calibration_input(text, "inverse.toml");
        } catch (const scene::SceneError &e) {
            return std::string(e.what());
        }
        return std::string();
    };
    auto refusal = [](const std::string &text) {
        try {
            pipeline::check_feasible(scene::calibration_input(text, "inverse.toml"));
        } catch (const std::invalid_argument &e) {
            return std::string(e.what());
        }
        return std::string();
    };
    const std::string base = plate_scene;
    EXPECT_EQ(scene_error(replace(base, "verify_tail_s = 0.01", "verify_tail_s = 0.01\nregularization = -0.1")),
              "inverse.toml: calibration.regularization: must be >= 0, got -0.1");
    EXPECT_EQ(scene_error(replace(base, "verify_tail_s = 0.01", "verify_tail_s = 0.01\nmethod = \"inverse\"")),
              "inverse.toml: calibration.method: unknown value \"inverse\" (known: time_reversal, inverse_filter)");
    EXPECT_EQ(scene_error(replace(base, "verify_tail_s = 0.01", "verify_tail_s = 0.01\nlead_time_s = 0")),
              "inverse.toml: calibration.lead_time_s: must be > 0, got 0");
    // The crossing: farthest exciter (0.021, 0.033) to farthest focus (0.2, 0.155) at the A0 group velocity.
    const pipeline::CalibrationInput in = scene::calibration_input(base, "inverse.toml");
    const double cg = 2 * std::sqrt(2 * std::numbers::pi * 1200 * in.plate->kappa());
    double far = 0;
    for (const auto &e : in.exciters.positions)
        for (const auto &f : in.foci.points)
            far = std::max(far, std::hypot(e.x_m - f.at.x_m, e.y_m - f.at.y_m));
    EXPECT_NEAR(pipeline::crossing_time_s(in, in.exciters.positions), far / cg, 1e-12);
    const std::string short_lead = refusal(replace(
        base, "verify_tail_s = 0.01", "verify_tail_s = 0.01\nlead_time_s = " + std::to_string(0.9 * far / cg)));
    EXPECT_EQ(short_lead.rfind("calibration.lead_time_s: ", 0), 0u) << short_lead;
    EXPECT_NE(short_lead.find("shorter than the plate crossing"), std::string::npos) << short_lead;
    EXPECT_EQ(short_lead.find('\n'), std::string::npos);
    EXPECT_EQ(refusal(replace(base, "verify_tail_s = 0.01",
                              "verify_tail_s = 0.01\nlead_time_s = " + std::to_string(1.1 * far / cg))),
              "");
    const std::string long_lead =
        refusal(replace(base, "verify_tail_s = 0.01", "verify_tail_s = 0.01\nlead_time_s = 0.0399"));
    EXPECT_EQ(long_lead.rfind("calibration.lead_time_s: ", 0), 0u) << long_lead;
    EXPECT_NE(long_lead.find("calibration.window_s"), std::string::npos) << long_lead;
}

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
    loud2[20 * C] = 30000;  // same block, same channel, orthogonal in time: energy 1/sqrt(2), peak 32767/60000
    EXPECT_NEAR(pipeline::mixer_gain({&loud, &loud2}, C), 32767.0 / 60000.0, 1e-12);
}

TEST(JointDesign, UnregularisedJointInverseIsExactAtEveryFocusOfTheSet)
{
    // Two foci of a set and one control point: Q = 3 rows, C = 4 exciters, so
    // MINT's exact FIR inverse exists at J >= Q (S - 1) / (C - Q) and both
    // foci get the pulse, the control point nothing, to solver precision.
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    const std::size_t S = 40, C = 4, Q = 3;
    const pipeline::TransferMatrix H = short_transfer(in, S);
    pipeline::InverseFilterOptions o;
    o.regularization = 0;
    pipeline::InverseFilterProblem p;
    p.foci = {0, 3};
    p.control = {1};
    p.drive_samples = (Q * (S - 1) + (C - Q) - 1) / (C - Q) + 1;
    p.target = pipeline::focus_target(in, H.rate_hz, double(p.drive_samples) / H.rate_hz);
    const auto d = pipeline::design_inverse_filter(H, p, o).drive;
    EXPECT_LT(residual_of(H, p, d).relative, 1e-6);
    // Each focus alone by direct convolution: the pulse, both of them.
    const std::size_t out = p.drive_samples + S - 1;
    double dd = 0;
    for (double v : p.target)
        dd += v * v;
    for (std::size_t f : p.foci) {
        const std::vector<double> w = play(H, d, f, out);
        double err = 0;
        for (std::size_t n = 0; n < out; n++) {
            const double t = n < p.target.size() ? p.target[n] : 0.0;
            err += (w[n] - t) * (w[n] - t);
        }
        EXPECT_LT(std::sqrt(err / dd), 1e-6) << "focus " << f;
    }
    // Not vacuous: the same drive length with a fourth row is overdetermined.
    p.control = {1, 2};
    EXPECT_GT(residual_of(H, p, pipeline::design_inverse_filter(H, p, o).drive).relative, 1e-2);
}

TEST(JointDesign, LeastSquaresOfASetIsTheSumOfItsSingleDesigns)
{
    // The normal equations are linear in the target: with the same rows (the
    // two foci and two control points, weight 1 each), G and beta are the
    // same for the set and for each single focus (whose control points
    // include the other focus), and b of the set is the sum of the singles'.
    // So the set's design is the sum of the single designs: what a joint
    // design adds over the firmware's superposition is its own control
    // points, its own minimax weights and its level, not the least squares.
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    const pipeline::TransferMatrix H = short_transfer(in, 96);
    pipeline::InverseFilterOptions o;
    o.regularization = 1e-4;
    o.minimax_iterations = 0;
    pipeline::InverseFilterProblem joint;
    joint.foci = {0, 3};
    joint.control = {1, 2};
    joint.drive_samples = 40;
    joint.target = pipeline::focus_target(in, H.rate_hz, 36.0 / H.rate_hz);
    const pipeline::InverseFilterDesign dj = pipeline::design_inverse_filter(H, joint, o);
    std::vector<std::vector<double>> sum(H.channels, std::vector<double>(joint.drive_samples, 0.0));
    for (std::size_t f : joint.foci) {
        pipeline::InverseFilterProblem one = joint;
        one.foci = {f};
        one.control = {1, 2, f == 0 ? 3u : 0u};
        const pipeline::InverseFilterDesign d = pipeline::design_inverse_filter(H, one, o);
        EXPECT_NEAR(d.beta, dj.beta, 1e-9 * dj.beta);
        for (std::size_t c = 0; c < H.channels; c++)
            for (std::size_t j = 0; j < joint.drive_samples; j++)
                sum[c][j] += d.drive[c][j];
    }
    double diff = 0, norm = 0;
    for (std::size_t c = 0; c < H.channels; c++)
        for (std::size_t j = 0; j < joint.drive_samples; j++) {
            diff += (dj.drive[c][j] - sum[c][j]) * (dj.drive[c][j] - sum[c][j]);
            norm += dj.drive[c][j] * dj.drive[c][j];
        }
    EXPECT_LT(std::sqrt(diff / norm), 1e-8);

    // And the set's design is the minimum of its objective, by direct
    // convolution: || A s - d ||^2 over both foci and the controls plus
    // beta || s ||^2 (s at the solver's scale, drive / R) is stationary
    // there (no first-order change along a seeded direction) and larger on
    // either side.
    double dd = 0;
    for (double v : joint.target)
        dd += v * v;
    auto objective = [&](const std::vector<std::vector<double>> &s) {
        const Residual r = residual_of(H, joint, s);
        const double n = r.drive_norm / H.rate_hz;
        return r.relative * r.relative * dd * double(joint.foci.size()) + dj.beta * n * n;
    };
    std::vector<std::vector<double>> plus = dj.drive, minus = dj.drive;
    for (std::size_t c = 0; c < H.channels; c++)
        for (std::size_t j = 0; j < joint.drive_samples; j++) {
            const double v = 0.05 * std::sqrt(norm / double(H.channels * joint.drive_samples)) *
                             std::sin(1.7 * double(j) + 2.3 * double(c) + 0.4);
            plus[c][j] += v;
            minus[c][j] -= v;
        }
    const double j0 = objective(dj.drive), jp = objective(plus), jm = objective(minus);
    EXPECT_GT(jp, j0);
    EXPECT_GT(jm, j0);
    EXPECT_LT(std::abs(jp - jm), 1e-4 * (jp + jm - 2 * j0));
}

TEST(JointDesign, PairsAndTriplesKeepTheSuperpositionsBudget)
{
    // Every pair and triple of the 2 x 2 foci, superposed and designed
    // jointly: the mix never has more energy than the mean of its foci alone
    // (the firmware's normalisation), neither has the joint drive, no touched
    // focus of the joint drive exceeds the scene's amplitude, and a set of
    // one designed jointly is the table's design.
    pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "inverse.toml");
    in.calibration.dither = false;
    in.calibration.lead_time_s = 0.006;
    in.calibration.method = pipeline::DriveMethod::inverse_filter;
    const pipeline::TransferMatrix H = pipeline::transfer_for(in, in.exciters.positions);
    pipeline::CalibrationResult r;
    r.exciters = in.exciters.positions;
    pipeline::signals_and_verification(in, H, {}, r);
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
    for (const pipeline::MultiTouchCase &c : rep.cases) {
        ASSERT_TRUE(c.has_joint);
        (c.foci.size() == 2 ? pairs : triples)++;
        double e_ref = 0;
        for (std::size_t f : c.foci)
            e_ref += energy[f] / double(c.foci.size());
        EXPECT_LE(c.superposed.energy, e_ref * (1 + 1e-6));
        EXPECT_LE(c.joint.energy, e_ref * (1 + 1e-6));
        EXPECT_LE(c.joint.gain, 1.0);
        EXPECT_GT(c.joint.min_focus_peak_m, 0.0);
        EXPECT_LE(c.joint.min_focus_peak_m, in.pulse.amplitude_m * (1 + 1e-6));
        EXPECT_EQ(c.superposed.ok, c.superposed.min_focus_peak_m >= in.calibration.threshold_m &&
                                       c.superposed.max_elsewhere_m < in.calibration.threshold_m);
    }
    // 2 x 2 foci more than lambda/2 (36 mm) apart: all 6 pairs, all 4 triples.
    EXPECT_EQ(pairs, 6u);
    EXPECT_EQ(triples, 4u);
}

TEST(Radiation, SmallBaffledPistonAndATone)
{
    // A 3 x 3 patch of lattice cells moving together, w(t) a Gaussian-windowed
    // 300 Hz sine, heard on axis at 0.5 m: a baffled piston much smaller than
    // the wavelength (1.1 m) and the distance, p(t) = rho0 A a(t - r / c0) / (2 pi r)
    // with a = w'' analytically.
    pipeline::ObservationLattice lat;
    lat.stride = 1;
    lat.cols = lat.rows = 11;
    lat.spacing_m = 0.01;
    const double R = 8000, f = 300, t0 = 0.05, sig = 0.006, z = 0.5;
    const std::size_t S = 1024;
    auto wt = [&](double t) {
        return 1e-6 * std::exp(-(t - t0) * (t - t0) / (2 * sig * sig)) * std::sin(2 * std::numbers::pi * f * (t - t0));
    };
    std::vector<std::vector<float>> w(lat.size());
    for (std::size_t n = 0; n < lat.size(); n++) {
        const int i = int(n % 11), j = int(n / 11);
        w[n].assign(S, 0.0f);
        if (std::abs(i - 5) <= 1 && std::abs(j - 5) <= 1)
            for (std::size_t s = 0; s < S; s++)
                w[n][s] = static_cast<float>(wt(double(s) / R));
    }
    const std::vector<double> p = pipeline::rayleigh_pressure(lat, w, R, {0.05, 0.05}, z, S);
    const double A = 9 * 0.01 * 0.01, delay = z / pipeline::sound_speed_m_s, h = 1e-5;
    double peak = 0, diff = 0;
    for (std::size_t s = 0; s < S; s++) {
        const double t = double(s) / R - delay;
        const double a = (wt(t + h) - 2 * wt(t) + wt(t - h)) / (h * h);
        const double exact = pipeline::air_density_kg_m3 * A * a / (2 * std::numbers::pi * z);
        peak = std::max(peak, std::abs(exact));
        diff = std::max(diff, std::abs(p[s] - exact));
    }
    ASSERT_GT(peak, 0);
    EXPECT_LT(diff, 0.01 * peak);  // float field, path differences of 0.04 mm over the patch

    // A-weighting (IEC 61672-1 table): 0.0 dB at 1 kHz, -19.1 dB at 100 Hz, -3.2 dB at 500 Hz, +1.3 dB at 2.5 kHz.
    EXPECT_NEAR(20 * std::log10(pipeline::a_weighting(1000)), 0.0, 0.05);
    EXPECT_NEAR(20 * std::log10(pipeline::a_weighting(100)), -19.1, 0.1);
    EXPECT_NEAR(20 * std::log10(pipeline::a_weighting(500)), -3.2, 0.1);
    EXPECT_NEAR(20 * std::log10(pipeline::a_weighting(2500)), 1.3, 0.1);
    // A 1 Pa, 1 kHz tone for 0.5 s (whole periods): exposure 0.5 x 0.5 Pa^2 s.
    std::vector<double> tone(4000);
    for (std::size_t s = 0; s < tone.size(); s++)
        tone[s] = std::sin(2 * std::numbers::pi * 1000 * double(s) / R);
    EXPECT_NEAR(pipeline::a_weighted_exposure(tone, R), 0.25, 0.25 * 0.01);
}

// The force energy of stored int16 signals, by hand: full scale 2 N at
// 1 kHz, samples +FS, -FS, 0 and 16384 (1.000031 N).
TEST(DriveFigures, ForceEnergyOfStoredSignalsByHand)
{
    const double half = 2.0 * 16384.0 / 32767.0;
    EXPECT_DOUBLE_EQ(pipeline::drive_energy_n2s({32767, -32767, 0, 16384}, 2.0, 1000.0),
                     (4.0 + 4.0 + 0.0 + half * half) / 1000.0);
    EXPECT_EQ(pipeline::drive_energy_n2s({}, 2.0, 1000.0), 0.0);
}
