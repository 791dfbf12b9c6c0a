// The transfer matrix against a second method: forward simulation of the same
// drives (the scheme is linear and time-invariant, so at the simulation rate
// with the impulse force the convolution with H is the simulation, to
// round-off), the decimated band-limited H against forward simulation within a
// stated tolerance, and reciprocity (exciter -> point equals point -> exciter).
#include "pipeline/calibrate.h"
#include "pipeline/signal/peaks.h"
#include "pipeline/transfer/playback.h"
#include "pipeline/transfer/transfer.h"
#include "pipeline/verification/verification.h"
#include "scene/calibration_input.h"
#include "scene_text.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

using namespace calib;

namespace {

// A small lossy acrylic plate (the demonstrator scaled down) in double precision.
const std::string plate_scene = scene_text::load("transfer.toml");

std::vector<pipeline::Point> foci_of(const pipeline::CalibrationInput &in)
{
    std::vector<pipeline::Point> p;
    for (const auto &f : in.foci.points)
        p.push_back(f.at);
    return p;
}

// A drive per exciter at the simulation rate: Hann bursts at 1.2 kHz with a
// delay per channel and per focus (a stand-in for time-reversal signals).
std::vector<std::vector<double>> burst_drive(std::size_t channels, double k, double delay_s)
{
    std::vector<std::vector<double>> f(channels);
    const double T = 2 / 1200.0;
    for (std::size_t c = 0; c < channels; c++) {
        const double t0 = delay_s + 0.0007 * double(c);
        const auto n = static_cast<std::size_t>(std::ceil((t0 + T) / k));
        f[c].assign(n, 0.0);
        for (std::size_t i = 0; i < n; i++) {
            const double t = double(i) * k - t0;
            if (t >= 0 && t < T)
                f[c][i] = (c ? -0.3 : 0.5) * std::pow(std::sin(std::numbers::pi * t / T), 2) *
                          std::sin(2 * std::numbers::pi * 1200 * t);
        }
    }
    return f;
}

// Forward simulation of a drive, recording the foci.
std::vector<std::vector<double>> forward(const pipeline::CalibrationInput &in,
                                         const std::vector<pipeline::Point> &exciters,
                                         const std::vector<std::vector<double>> &force, std::size_t steps)
{
    engine::Simulation sim(in.plate, pipeline::single_core_options(in));
    for (std::size_t c = 0; c < exciters.size(); c++)
        sim.set_source_signal(sim.add_source(exciters[c].x_m, exciters[c].y_m), force[c]);
    for (const auto &p : foci_of(in))
        sim.add_receiver(p.x_m, p.y_m);
    sim.run(steps);
    return sim.traces();
}

} // namespace

TEST(Transfer, ConvolutionEqualsForwardSimulationAtTheSimulationRate)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "transfer.toml");
    const std::vector<pipeline::Point> ex = in.exciters.positions;
    engine::Simulation probe(in.plate, pipeline::single_core_options(in));
    const double k = probe.time_step_s();
    pipeline::TransferOptions o; // decimation 1, the scheme's own impulse response
    o.samples = probe.steps_for(0.02);
    const pipeline::TransferMatrix H = pipeline::simulate_transfer(in, ex, foci_of(in), o);
    ASSERT_EQ(H.rate_hz, 1.0 / k);

    const std::vector<std::vector<double>> a = burst_drive(ex.size(), k, 0.0);   // focus A's drive
    const std::vector<std::vector<double>> b = burst_drive(ex.size(), k, 0.003); // focus B's drive
    std::vector<std::vector<double>> sum = a;                                    // the superposition
    for (std::size_t c = 0; c < sum.size(); c++) {
        sum[c].resize(std::max(a[c].size(), b[c].size()), 0.0);
        for (std::size_t i = 0; i < b[c].size(); i++)
            sum[c][i] += b[c][i];
    }
    std::size_t drive = 0;
    for (const auto &c : sum)
        drive = std::max(drive, c.size());
    const std::size_t out = o.samples;
    pipeline::Playback pb(H, {H.exact_begin(), H.exact_begin() + 1}, drive, out);
    const std::vector<std::vector<double>> &ab = sum;
    for (const std::vector<std::vector<double>> *d : {&a, &b, &ab}) {
        const auto conv = pb.field(*d);
        const auto sim = forward(in, ex, *d, out);
        for (std::size_t g = 0; g < 2; g++) {
            double peak = 0, diff = 0;
            for (std::size_t n = 0; n < out; n++) {
                peak = std::max(peak, std::abs(sim[g][n]));
                diff = std::max(diff, std::abs(sim[g][n] - double(conv[g][n])));
            }
            ASSERT_GT(peak, 0);
            // H and the FFT are single precision: round-off of a few 1e-7 of the peak per term.
            EXPECT_LT(diff, 2e-5 * peak) << "focus " << g;
        }
    }
    // Not vacuous: the response one exciter would give is a different field.
    const auto conv = pb.field(a);
    auto one = a;
    one[1].assign(one[1].size(), 0.0);
    const auto sim_one = forward(in, ex, one, out);
    double moved = 0, peak = 0;
    for (std::size_t n = 0; n < out; n++) {
        moved = std::max(moved, std::abs(sim_one[0][n] - double(conv[0][n])));
        peak = std::max(peak, std::abs(double(conv[0][n])));
    }
    EXPECT_GT(moved, 0.05 * peak);

    // Each exciter's part alone (channel_fields, what time reversal's gains
    // are judged on): the parts of the drive without exciter 1 equal the
    // forward run of that drive, and every drive's parts add up to its field.
    const auto parts = pb.channel_fields(one, {0, 1});
    ASSERT_EQ(parts.size(), ex.size());
    double part_diff = 0, part_peak = 0;
    for (std::size_t n = 0; n < out; n++) {
        double sum_one = 0;
        for (std::size_t c = 0; c < ex.size(); c++)
            sum_one += parts[c][0][n];
        part_diff = std::max(part_diff, std::abs(sim_one[0][n] - sum_one));
        part_peak = std::max(part_peak, std::abs(sim_one[0][n]));
        EXPECT_EQ(parts[1][0][n], 0.0f); // exciter 1 plays nothing
    }
    EXPECT_LT(part_diff, 2e-5 * part_peak);
    const auto whole = pb.field(a);
    const auto split = pb.channel_fields(a, {0, 1});
    for (std::size_t g = 0; g < 2; g++)
        for (std::size_t n = 0; n < out; n++) {
            double sum_a = 0;
            for (std::size_t c = 0; c < ex.size(); c++)
                sum_a += split[c][g][n];
            ASSERT_NEAR(sum_a, whole[g][n], 2e-5 * peak) << "point " << g << " sample " << n;
        }
}

TEST(Transfer, DecimatedBandLimitedMatrixMatchesForwardSimulationWithinTolerance)
{
    // The calibration's H (band-limited force, every M-th step, the lattice)
    // against the forward path for a drive at the device rate: the focal peak
    // within 0.5 % and the waveform within 2 % of the peak. The residual is
    // the force's pass band ripple (1e-4), its stop-band leakage (-80 dB) and
    // the peak refinement (1e-4), well inside; dither is off.
    pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "transfer.toml");
    in.calibration.dither = false;
    const std::vector<pipeline::Point> ex = in.exciters.positions;
    const pipeline::TransferMatrix H = pipeline::transfer_for(in, ex);
    EXPECT_GT(H.decimation, 1u);
    EXPECT_GT(H.lattice.size(), 0u);
    // 48 kHz drive frames [n][c] at full scale 1.0: a Hann burst per channel.
    const double rate = 48000;
    const auto burst = burst_drive(ex.size(), 1 / rate, 0.001);
    std::vector<float> frames(burst[1].size() * ex.size(), 0.0f);
    for (std::size_t c = 0; c < ex.size(); c++)
        for (std::size_t i = 0; i < burst[c].size(); i++)
            frames[i * ex.size() + c] = static_cast<float>(burst[c][i]);
    const pipeline::Verification conv = pipeline::verify_drive_with(in, H, frames, unsigned(ex.size()), rate);
    const pipeline::Verification fwd = pipeline::verify_drive_forward(in, ex, frames, unsigned(ex.size()), rate, {});
    for (std::size_t g = 0; g < 2; g++) {
        const double p = fwd.foci[g].peak_m;
        ASSERT_GT(p, 0);
        EXPECT_NEAR(conv.foci[g].peak_m, p, 5e-3 * p) << "focus " << g;
        EXPECT_NEAR(conv.foci[g].lead_time_s, fwd.foci[g].lead_time_s, 1 / H.rate_hz);
        // Waveform: the forward trace at the decimated instants.
        const auto &c = conv.traces[0][g];
        const auto &f = fwd.traces[0][g];
        double diff = 0;
        for (std::size_t s = 0; s < c.size() && s * H.decimation < f.size(); s++)
            diff = std::max(diff, std::abs(c[s] - f[s * H.decimation]));
        EXPECT_LT(diff, 0.02 * p) << "focus " << g;
    }
}

TEST(Transfer, ReciprocityExciterToPointEqualsPointToExciter)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene, "transfer.toml");
    const pipeline::Point exciter = in.exciters.positions[0], point{0.1737, 0.1213}; // neither on a node
    engine::Simulation probe(in.plate, pipeline::single_core_options(in));
    const pipeline::TransferOptions o = pipeline::transfer_options(in, probe.time_step_s());
    const pipeline::TransferMatrix a = pipeline::simulate_transfer(in, {exciter}, {point}, o);
    const pipeline::TransferMatrix b = pipeline::simulate_transfer(in, {point}, {exciter}, o);
    const pipeline::TransferMatrix c = pipeline::simulate_transfer(in, {exciter}, {{point.x_m + 0.004, point.y_m}}, o);
    const float *ha = a.response(0, a.exact_begin()), *hb = b.response(0, b.exact_begin());
    const float *hc = c.response(0, c.exact_begin());
    double peak = 0, diff = 0, moved = 0;
    for (std::size_t s = 0; s < a.samples; s++) {
        peak = std::max(peak, double(std::abs(ha[s])));
        diff = std::max(diff, double(std::abs(ha[s] - hb[s])));
        moved = std::max(moved, double(std::abs(ha[s] - hc[s])));
    }
    ASSERT_GT(peak, 0);
    EXPECT_LT(diff, 1e-6 * peak);  // float storage of a double simulation
    EXPECT_GT(moved, 1e-2 * peak); // 4 mm away is a different response
}

TEST(Transfer, RefinedPeakRecoversASampledSinePeak)
{
    // 300 Hz at 2.9 kHz, the peak midway between samples: the samples show
    // cos(pi f / rate) = 0.947 of it; the refinement recovers it to 1e-3.
    const double rate = 2900, f = 300;
    std::vector<float> x(200);
    for (std::size_t n = 0; n < x.size(); n++) {
        const double t = (double(n) - 100.5) / rate;
        x[n] = static_cast<float>(std::cos(2 * std::numbers::pi * f * t) * std::exp(-t * t / (2 * 0.004 * 0.004)));
    }
    const pipeline::Peak p = pipeline::refined_peak(x);
    EXPECT_LT(pipeline::sample_peak(x.data(), x.size()), 0.96);
    EXPECT_NEAR(p.value, 1.0, 1e-3);
    EXPECT_NEAR(p.index, 100.5, 0.02);
}
