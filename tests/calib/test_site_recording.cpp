// The placement's decimated site recordings against a second method: the
// same plate driven by the one-step impulse and read by the engine's own
// receivers at every step. The scheme is linear and time-invariant, so the
// band-limited force's response is the impulse response convolved with the
// force; every M-th sample of that convolution is what the decimated
// recording must hold, to float round-off (the field copies are float).
#include "pipeline/calibrate.h"
#include "pipeline/plan.h"
#include "pipeline/placement/site_recording.h"
#include "pipeline/design/time_reversal.h"
#include "pipeline/transfer/transfer.h"
#include "pipeline/signal/pulse.h"
#include "pipeline/signal/resample.h"
#include "scene/calibration_input.h"

#include "scene_text.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

using namespace calib;

namespace {

// A small lossy acrylic plate (the demonstrator scaled down), in the given precision.
std::string plate_scene(const std::string &precision)
{
    return scene_text::replace(scene_text::load("sites.toml"), "precision = \"double\"",
                               "precision = \"" + precision + "\"");
}

const std::vector<pipeline::Point> sites = {
    {0.021, 0.033}, {0.273, 0.205}, {0.015, 0.12}, {0.15, 0.228}, {0.2871, 0.0173}};
const pipeline::Point source{0.1, 0.1};

// Every step of the one-step impulse's response at the sites (receivers).
std::vector<std::vector<double>> full_rate(const pipeline::CalibrationInput &in, std::size_t steps)
{
    engine::Simulation sim(in.plate, pipeline::single_core_options(in));
    sim.set_source_impulse(sim.add_source(source.x_m, source.y_m));
    for (const pipeline::Point &p : sites)
        sim.add_receiver(p.x_m, p.y_m);
    sim.run(steps);
    return sim.traces();
}

double peak_of(const std::vector<std::vector<double>> &x)
{
    double m = 0;
    for (const auto &t : x)
        for (double v : t)
            m = std::max(m, std::abs(v));
    return m;
}

} // namespace

// The band-limited force's response read every M-th step off the field
// copies = the receivers' full-rate impulse response convolved with the same
// force (N per step, times k) and sampled at centre + s M.
TEST(SiteRecording, DecimatedEqualsFullRateFilteredAndDecimated)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene("double"), "sites.toml");
    engine::Simulation sim(in.plate, pipeline::single_core_options(in));
    const double k = sim.time_step_s();
    const pipeline::SiteRecordingOptions o = pipeline::site_recording_options(k, 1.0 / (9 * k));
    ASSERT_EQ(o.decimation, 4u);
    const std::size_t steps = sim.steps_for(in.calibration.window_s);
    const pipeline::SiteRecording rec = pipeline::record_sites(sim, source, sites, steps, o);
    ASSERT_EQ(rec.traces.size(), sites.size());
    const std::size_t S = (steps + 3) / 4;
    ASSERT_EQ(rec.traces[0].size(), S);
    EXPECT_DOUBLE_EQ(rec.rate_hz, 1.0 / (4 * k));

    std::size_t centre = 0;
    const std::vector<double> b = pipeline::band_limited_impulse(k, o.pass_hz, o.stop_hz, centre);
    const std::vector<std::vector<double>> g = full_rate(in, centre + (S - 1) * 4 + 1);
    std::vector<std::vector<double>> want(sites.size(), std::vector<double>(S));
    for (std::size_t i = 0; i < sites.size(); i++)
        for (std::size_t s = 0; s < S; s++) {
            const std::size_t n = centre + s * 4;
            double acc = 0;
            for (std::size_t m = 0; m < b.size() && m <= n; m++)
                acc += b[m] * k * g[i][n - m];
            want[i][s] = acc;
        }
    const double peak = peak_of(want);
    ASSERT_GT(peak, 0);
    double worst = 0;
    for (std::size_t i = 0; i < sites.size(); i++)
        for (std::size_t s = 0; s < S; s++)
            worst = std::max(worst, std::abs(rec.traces[i][s] - want[i][s]));
    std::printf("decimated vs full rate filtered: max difference %.3g of the peak\n", worst / peak);
    EXPECT_LT(worst, 1e-6 * peak);
}

// Without decimation (the one-step impulse, every step) a float engine's
// field copies read with the receivers' weights give the receivers' values
// bit for bit.
TEST(SiteRecording, UndecimatedIsTheReceiversExactly)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene("float"), "sites.toml");
    engine::Simulation sim(in.plate, pipeline::single_core_options(in));
    const std::size_t steps = 700;
    const pipeline::SiteRecording rec = pipeline::record_sites(sim, source, sites, steps, {});
    const std::vector<std::vector<double>> g = full_rate(in, steps);
    ASSERT_GT(peak_of(g), 0);
    for (std::size_t i = 0; i < sites.size(); i++) {
        ASSERT_EQ(rec.traces[i].size(), steps);
        for (std::size_t n = 0; n < steps; n++)
            ASSERT_EQ(rec.traces[i][n], g[i][n]) << "site " << i << " step " << n;
    }
}

// What the placement search receives: the decimated recordings resampled to
// the search rate agree with the full-rate traces resampled (the path before
// decimation) within the force's pass-band ripple, up to the last samples
// where each path's own end of the window (a truncation soxr smooths) shows.
TEST(SiteRecording, SearchRateResponsesMatchTheFullRatePath)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene("float"), "sites.toml");
    engine::Simulation sim(in.plate, pipeline::single_core_options(in));
    const double k = sim.time_step_s();
    const double R = pipeline::search_rate(in.pulse);
    const pipeline::SiteRecordingOptions o = pipeline::site_recording_options(k, R);
    ASSERT_GE(o.decimation, 2u);
    const std::size_t steps = sim.steps_for(in.calibration.window_s);
    const std::vector<std::vector<double>> got =
        pipeline::site_responses_at(pipeline::record_sites(sim, source, sites, steps, o), k, steps, R);
    const std::vector<std::vector<double>> g = full_rate(in, steps);
    std::vector<std::vector<double>> want;
    for (const auto &t : g)
        want.push_back(pipeline::resample(t, 1.0 / k, R));
    ASSERT_EQ(got[0].size(), want[0].size());
    const double peak = peak_of(want);
    const std::size_t n = want[0].size(), tail = n / 10;
    double worst = 0;
    for (std::size_t i = 0; i < sites.size(); i++)
        for (std::size_t s = 0; s + tail < n; s++)
            worst = std::max(worst, std::abs(got[i][s] - want[i][s]));
    std::printf("search-rate responses: M = %zu, max difference %.3g of the peak (first %zu of %zu samples)\n",
                o.decimation, worst / peak, n - tail, n);
    EXPECT_LT(worst, 1e-3 * peak);
}

// The plan prices what the simulations do: the decimation and the steps
// (window and the sinc's delay) of a reciprocity simulation.
TEST(SiteRecording, PlanCarriesTheRecording)
{
    const pipeline::CalibrationInput in = scene::calibration_input(plate_scene("float"), "sites.toml");
    const pipeline::CalibrationPlan p = pipeline::plan(in);
    const pipeline::SiteRecordingOptions o = pipeline::site_recording_options(p.time_step_s, p.search_rate_hz);
    EXPECT_EQ(p.site_decimation, o.decimation);
    EXPECT_GE(o.decimation, 2u);
    EXPECT_GE(1.0 / (double(o.decimation) * p.time_step_s), 2 * p.search_rate_hz);
    EXPECT_EQ(p.site_steps, p.window_steps + pipeline::site_recording_delay_steps(p.time_step_s, o));
    EXPECT_GT(p.site_steps, p.window_steps);
}
