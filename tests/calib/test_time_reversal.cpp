// Pulse shapes and time-reversal signal processing, against analytic truth:
// a free-space delay-and-attenuate Green's function where the refocused pulse
// must appear at the focus at the predicted instant, exact sines for the
// resampler, and the statistics of TPDF dither.
#include "pipeline/signal/pulse.h"
#include "pipeline/design/time_reversal.h"
#include "pipeline/signal/resample.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numbers>
#include <numeric>

using namespace calib::pipeline;
using std::numbers::pi;

TEST(Pulse, HannBurstIsZeroAtItsEndsAndBandLimitedAroundItsCentre)
{
    PulseSpec p{PulseShape::hann_burst, 300.0, 2.0, 10e-6};
    EXPECT_DOUBLE_EQ(pulse_duration_s(p), 2.0 / 300.0);
    EXPECT_NEAR(pulse_value(p, 0.0), 0.0, 1e-15);
    EXPECT_EQ(pulse_value(p, pulse_duration_s(p)), 0.0);
    EXPECT_EQ(pulse_value(p, -1e-3), 0.0);
    // A Hann window of length T has its first spectral zero at 2/T from the
    // carrier and sidelobes below -31.5 dB: at the 1 % level the band ends
    // between the main lobe's edge and the second sidelobe's.
    const double T = pulse_duration_s(p), fmax = pulse_max_frequency_hz(p, 0.01);
    EXPECT_GT(fmax, 300.0 + 2.0 / T);
    EXPECT_LT(fmax, 300.0 + 4.0 / T);
    // A long burst is narrow-band: 40 cycles -> main lobe +-2/T = +-15 Hz.
    PulseSpec narrow{PulseShape::hann_burst, 300.0, 40.0, 10e-6};
    EXPECT_NEAR(pulse_max_frequency_hz(narrow, 0.01), 300.0, 4.0 / pulse_duration_s(narrow));
    EXPECT_GT(pulse_max_frequency_hz(p, 0.001), fmax);
}

TEST(Pulse, ShapesParseAndRickerPeaksAtItsCentre)
{
    EXPECT_EQ(parse_pulse_shape("ricker"), PulseShape::ricker);
    EXPECT_THROW(parse_pulse_shape("square"), std::invalid_argument);
    PulseSpec r{PulseShape::ricker, 200.0, 0, 1e-6};
    EXPECT_NEAR(pulse_value(r, pulse_duration_s(r) / 2), 1.0, 1e-12);
    EXPECT_LT(std::abs(pulse_value(r, 1e-9)), 2e-4);
    PulseSpec g{PulseShape::gaussian_burst, 200.0, 3, 1e-6};
    EXPECT_NEAR(std::abs(pulse_value(g, 1e-12)), 0.0, 0.011); // -40 dB envelope at the ends
}

TEST(Resample, SineKeepsItsValuesAtTheNewRate)
{
    const double fin = 20000, fout = 48000, f = 440;
    std::vector<double> x(4000);
    for (size_t i = 0; i < x.size(); i++)
        x[i] = std::sin(2 * pi * f * static_cast<double>(i) / fin);
    std::vector<double> y = resample(x, fin, fout);
    ASSERT_NEAR(static_cast<double>(y.size()), x.size() * fout / fin, 1.0);
    double err = 0;
    for (size_t i = y.size() / 4; i < 3 * y.size() / 4; i++) // away from the ends' filter transients
        err = std::max(err, std::abs(y[i] - std::sin(2 * pi * f * static_cast<double>(i) / fout)));
    EXPECT_LT(err, 1e-4);
}

TEST(Resample, ManySignalsInGroupsAreEachTheSameBytesAsAlone)
{
    // More channels than two groups (the last one short): each output is the
    // same bytes as that signal resampled alone, whichever group it fell in,
    // and a sine of its own frequency at the new rate.
    const double fin = 5107.3, fout = 2400;
    const std::size_t channels = 2 * resample_group_channels + 5;
    std::vector<std::vector<double>> x(channels, std::vector<double>(1020));
    for (std::size_t c = 0; c < channels; c++)
        for (std::size_t i = 0; i < x[c].size(); i++)
            x[c][i] = std::sin(2 * pi * (50.0 + 10.0 * double(c)) * double(i) / fin);
    const std::vector<std::vector<double>> y = resample_all(x, fin, fout);
    ASSERT_EQ(y.size(), channels);
    for (std::size_t c = 0; c < channels; c++) {
        const std::vector<double> alone = resample(x[c], fin, fout);
        ASSERT_EQ(y[c].size(), alone.size()) << "channel " << c;
        EXPECT_EQ(0, std::memcmp(y[c].data(), alone.data(), alone.size() * sizeof(double))) << "channel " << c;
        const double f = 50.0 + 10.0 * double(c);
        double err = 0;
        for (std::size_t i = y[c].size() / 4; i < 3 * y[c].size() / 4; i++)
            err = std::max(err, std::abs(y[c][i] - std::sin(2 * pi * f * double(i) / fout)));
        EXPECT_LT(err, 1e-4) << "channel " << c << " (" << f << " Hz)";
    }
}

namespace {
struct FreeSpace { // non-dispersive 2-D propagation: delay r/c, amplitude 1/sqrt(r)
    double c = 150.0;
    double delay(double r) const { return r / c; }
    static double amp(double r) { return 1.0 / std::sqrt(r); }
};
double dist(double ax, double ay, double bx, double by) { return std::hypot(ax - bx, ay - by); }
} // namespace

TEST(TimeReversal, RefocusesAtTheFocusAtThePredictedInstant)
{
    const double sim_rate = 20000, window = 0.06;
    const PulseSpec pulse{PulseShape::hann_burst, 300, 2, 1e-5};
    const double T = pulse_duration_s(pulse);
    const double ex[8][2] = {{0.02, 0.05}, {0.31, 0.02}, {0.66, 0.04}, {0.68, 0.37},
                             {0.65, 0.66}, {0.35, 0.69}, {0.03, 0.62}, {0.05, 0.28}};
    const double fx = 0.40, fy = 0.42, ox = 0.25, oy = 0.30; // focus, and another point
    FreeSpace g;
    const auto n = static_cast<size_t>(window * sim_rate);
    std::vector<std::vector<double>> rec(8, std::vector<double>(n));
    for (int i = 0; i < 8; i++) {
        const double r = dist(ex[i][0], ex[i][1], fx, fy);
        for (size_t k = 0; k < n; k++)
            rec[i][k] = g.amp(r) * pulse_value(pulse, static_cast<double>(k) / sim_rate - g.delay(r));
    }
    TimeReversalOptions o;
    o.truncate_fraction = 0.5; // 30 ms: all direct arrivals (< 4 ms + T) are kept
    o.taper_s = 0.0005;
    DriveSignals d = make_drive_signals(rec, sim_rate, T, o);
    ASSERT_EQ(d.channels, 8u);
    EXPECT_NEAR(d.focus_delay_s, (600 - 1) / sim_rate - T / 2, 1e-12);

    // Play the quantized signals into the same medium (linear interpolation at 48 kHz).
    auto field_at = [&](double px, double py, double t) {
        double sum = 0;
        for (int i = 0; i < 8; i++) {
            const double r = dist(ex[i][0], ex[i][1], px, py);
            const double u = (t - g.delay(r)) * d.rate_hz;
            if (u < 0 || u >= static_cast<double>(d.frames - 1))
                continue;
            const auto k = static_cast<size_t>(u);
            const double a = d.samples[k * 8 + i], b = d.samples[(k + 1) * 8 + i];
            sum += g.amp(r) * (a + (u - static_cast<double>(k)) * (b - a));
        }
        return sum;
    };
    // Time reversal of p gives p(T_keep - t) at the focus: the reversed pulse
    // occupying [T_keep - T, T_keep]; find the best-matching offset.
    const double tk = d.focus_delay_s + T / 2, dt = 1.0 / d.rate_hz;
    double best_score = -1, best_off = 0;
    for (double off = -0.002; off <= 0.002; off += dt) {
        double s = 0;
        for (double t = 0; t < T; t += dt)
            s += field_at(fx, fy, tk - T + off + t) * pulse_value(pulse, T - t);
        if (s > best_score) {
            best_score = s;
            best_off = off;
        }
    }
    EXPECT_LE(std::abs(best_off), 1.5 * dt);
    double peak_focus = 0, peak_other = 0;
    for (double t = 0; t < 0.05; t += dt) {
        peak_focus = std::max(peak_focus, std::abs(field_at(fx, fy, t)));
        peak_other = std::max(peak_other, std::abs(field_at(ox, oy, t)));
    }
    EXPECT_GT(peak_focus, 2.0 * peak_other);
}

TEST(TimeReversal, TruncatesReversesNormalizesAndFades)
{
    const double rate = 48000;
    std::vector<std::vector<double>> rec(2, std::vector<double>(1000));
    for (size_t k = 0; k < 1000; k++) {
        rec[0][k] = std::sin(2 * pi * 500 * static_cast<double>(k) / rate) * 1e-7;
        rec[1][k] = k == 100 ? 3e-7 : 0.0; // an impulse at sample 100
    }
    TimeReversalOptions o;
    o.truncate_fraction = 0.3;
    o.taper_s = 0.0005; // 24 samples
    o.dither = false;
    DriveSignals d = make_drive_signals(rec, rate, 0.001, o);
    ASSERT_EQ(d.frames, 300u); // same rate: no resampling
    // Channel 1: impulse at 100 of the kept 300 -> index 299 - 100 after reversal.
    EXPECT_EQ(d.samples[199 * 2 + 1], 32767);
    EXPECT_NEAR(d.gain, 32767 / 3e-7, 1e-3 * 32767 / 3e-7);
    // Channel 0: reversed sine, faded at both ends (first sample far below its undamped value).
    EXPECT_LT(std::abs(d.normalized[0]), 0.01);
    EXPECT_LT(std::abs(d.normalized[299 * 2]), 0.01);
    const double mid = rec[0][299 - 150] * d.gain / 32767;
    EXPECT_NEAR(d.normalized[150 * 2], mid, 1e-12);
}

TEST(TimeReversal, TpdfDitherIsBoundedUnbiasedAndReproducible)
{
    const double rate = 48000;
    std::vector<std::vector<double>> rec(1, std::vector<double>(200000));
    for (size_t k = 0; k < rec[0].size(); k++)
        rec[0][k] = std::sin(0.001 * static_cast<double>(k)) + 0.3 * std::sin(0.0173 * static_cast<double>(k));
    TimeReversalOptions o;
    o.truncate_fraction = 1.0;
    DriveSignals a = make_drive_signals(rec, rate, 0.0, o);
    double mean = 0, var = 0;
    for (size_t i = 0; i < a.frames; i++) {
        const double e = a.samples[i] - a.normalized[i] * 32767.0;
        ASSERT_LE(std::abs(e), 1.5);
        mean += e;
        var += e * e;
    }
    mean /= static_cast<double>(a.frames);
    var /= static_cast<double>(a.frames);
    EXPECT_NEAR(mean, 0.0, 0.01);
    EXPECT_NEAR(var, 1.0 / 6 + 1.0 / 12, 0.02); // TPDF (1/6) + rounding (1/12) LSB^2
    DriveSignals b = make_drive_signals(rec, rate, 0.0, o);
    EXPECT_EQ(a.samples, b.samples);
    o.dither_seed = 2;
    DriveSignals c = make_drive_signals(rec, rate, 0.0, o);
    EXPECT_NE(a.samples, c.samples);
}

TEST(TimeReversal, DegenerateInputsGiveClearErrorsNotNaN)
{
    std::vector<std::vector<double>> zero(8, std::vector<double>(100, 0.0));
    try {
        make_drive_signals(zero, 48000, 0.001, {});
        FAIL() << "all-zero recordings accepted";
    } catch (const std::invalid_argument &e) {
        EXPECT_NE(std::string(e.what()).find("all recordings are zero"), std::string::npos);
    }
    std::vector<std::vector<double>> nan(2, std::vector<double>(100, 1.0));
    nan[1][10] = std::nan("");
    try {
        TimeReversalOptions o;
        o.truncate_fraction = 1.0;
        make_drive_signals(nan, 48000, 0.001, o);
        FAIL() << "NaN accepted";
    } catch (const std::invalid_argument &e) {
        EXPECT_NE(std::string(e.what()).find("channel 1"), std::string::npos);
    }
    EXPECT_THROW(make_drive_signals({}, 48000, 0.001, {}), std::invalid_argument);
    TimeReversalOptions bad;
    bad.truncate_fraction = 0;
    EXPECT_THROW(make_drive_signals(nan, 48000, 0.001, bad), std::invalid_argument);
}
