// The bench's excitation and its deconvolution (docs/bench.md): the
// exponential sweep's instantaneous frequency against the analytic phase, the
// plan's layout, and the impulse response of a simulated plate recovered from
// its recording of the plan's quantised sweep within the noise's predicted
// level; a null in the excitation does not blow the estimate up.
#include "engine/simulation.h"
#include "pipeline/signal/deconvolve.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/signal/resample.h"
#include "pipeline/signal/sweep.h"
#include "scene/scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

using namespace calib;
using pipeline::SweepSpec;

namespace {

SweepSpec sweep_50_5000()
{
    SweepSpec s;
    s.f1_hz = 50;
    s.f2_hz = 5000;
    s.duration_s = 2;
    s.rate_hz = 48000;
    s.amplitude = 0.5;
    return s;
}

} // namespace

// Every zero crossing of the sampled sweep falls where the analytic phase
// phi(t) = 2 pi f1 L (exp(t / L) - 1) is a multiple of pi, one multiple after
// the other (none missed), and the spacing of crossings gives the
// instantaneous frequency f1 exp(t / L): f1 to f2, exponentially.
TEST(Sweep, ZeroCrossingsFollowTheExponentialPhase)
{
    const SweepSpec s = sweep_50_5000();
    const std::vector<double> x = pipeline::exponential_sweep(s);
    ASSERT_EQ(x.size(), 96000u);
    // Crossings up to the fade-out's last 5 ms, where the envelope falls to 0
    // as fast as the sine turns and a straight line between two samples no
    // longer finds the zero.
    const std::size_t end = x.size() - std::size_t(0.005 * s.rate_hz);
    std::vector<double> t_cross;
    for (std::size_t i = 1; i + 1 < end; i++)
        if ((x[i] < 0) != (x[i + 1] < 0) && x[i] != 0)
            t_cross.push_back((double(i) + x[i] / (x[i] - x[i + 1])) / s.rate_hz);
    long previous = 0;
    double worst = 0;
    for (double t : t_cross) {
        const double k = pipeline::sweep_phase(s, t) / std::numbers::pi;
        const long n = std::lround(k);
        worst = std::max(worst, std::abs(k - double(n)));
        EXPECT_EQ(n, previous + 1) << "crossing at " << t << " s";
        previous = n;
    }
    EXPECT_LT(worst, 2e-3) << "phase error at a zero crossing, in units of pi";
    // Every half period of the phase up to there is there.
    EXPECT_EQ(previous, long(std::floor(pipeline::sweep_phase(s, double(end) / s.rate_hz) / std::numbers::pi)));
    // Instantaneous frequency from the spacing of crossings.
    double worst_rel = 0;
    for (std::size_t j = 0; j + 1 < t_cross.size(); j++) {
        const double f = 0.5 / (t_cross[j + 1] - t_cross[j]);
        const double mid = 0.5 * (t_cross[j] + t_cross[j + 1]);
        const double expect = s.f1_hz * std::exp(mid * std::log(s.f2_hz / s.f1_hz) / s.duration_s);
        worst_rel = std::max(worst_rel, std::abs(f / expect - 1));
    }
    EXPECT_LT(worst_rel, 5e-3); // the crossings' interpolation: 1e-2 of a sample in 4.8 at 5 kHz
    // From f1 to f2: the first and last half periods (the first one centred
    // 15 ms in, where the sweep is at 51.7 Hz already), within 5 %.
    EXPECT_NEAR(0.5 / (t_cross[1] - t_cross[0]), s.f1_hz, 0.05 * s.f1_hz);
    EXPECT_NEAR(0.5 / (t_cross.back() - t_cross[t_cross.size() - 2]), s.f2_hz, 0.05 * s.f2_hz);
    // The amplitude between the fades, and the fades' ends at zero.
    double peak = 0;
    for (double v : x)
        peak = std::max(peak, std::abs(v));
    EXPECT_NEAR(peak, 0.5, 1e-3);
    EXPECT_EQ(x[0], 0.0);
    EXPECT_LT(std::abs(x.back()), 1e-3);
    // The second harmonic's lead: L ln 2.
    EXPECT_NEAR(pipeline::harmonic_lead_s(s, 2), 2 / std::log(100.0) * std::log(2.0), 1e-12);
}

TEST(Sweep, RefusesABandOutsideTheRate)
{
    SweepSpec s = sweep_50_5000();
    s.f2_hz = 24000;
    EXPECT_THROW(pipeline::exponential_sweep(s), std::invalid_argument);
    s = sweep_50_5000();
    s.amplitude = 1.5;
    EXPECT_THROW(pipeline::exponential_sweep(s), std::invalid_argument);
}

TEST(Sweep, SnrRuleAndItsInverse)
{
    EXPECT_NEAR(pipeline::deconvolved_snr_db(30, 2, 5000), 30 + 10 * std::log10(1e4), 1e-12);
    EXPECT_NEAR(pipeline::sweep_s_for_snr(70, 30, 5000), 2, 1e-12);
}

// Channel c of the plan is the quantised sweep from start_frames[c] and zero
// everywhere else; the segments follow each other after the lead-in, each
// sweep then its gap.
TEST(Sweep, PlanLayoutDrivesOneExciterAtATime)
{
    SweepSpec s = sweep_50_5000();
    s.duration_s = 0.25;
    const std::vector<int16_t> q = pipeline::quantize_pcm16(pipeline::exponential_sweep(s));
    const pipeline::PlanLayout p = pipeline::plan_layout(3, 1000, q.size(), 500);
    ASSERT_EQ(p.start_frames, (std::vector<std::size_t>{1000, 1000 + 12500, 1000 + 2 * 12500}));
    ASSERT_EQ(p.total_frames, 1000u + 3 * 12500);
    const std::vector<int16_t> plan = pipeline::plan_samples(p, q);
    ASSERT_EQ(plan.size(), p.total_frames * 3);
    for (std::size_t c = 0; c < 3; c++) {
        std::size_t first = SIZE_MAX, last = 0;
        for (std::size_t n = 0; n < p.total_frames; n++) {
            const int16_t v = plan[n * 3 + c];
            const bool inside = n >= p.start_frames[c] && n < p.start_frames[c] + q.size();
            if (inside)
                ASSERT_EQ(v, q[n - p.start_frames[c]]) << "channel " << c << " frame " << n;
            else
                ASSERT_EQ(v, 0) << "channel " << c << " frame " << n;
            if (v != 0) {
                first = std::min(first, n);
                last = n;
            }
        }
        EXPECT_LE(p.start_frames[c], first);
        EXPECT_LT(last, p.start_frames[c] + q.size());
        EXPECT_GT(last, p.start_frames[c] + q.size() - 100); // the sweep runs to its end
    }
    // Quantisation: round(32768 x), clamped.
    EXPECT_EQ(pipeline::quantize_pcm16({0.5, -1.0, 1.0, 1e-5, -0.25})[0], 16384);
    EXPECT_EQ(pipeline::quantize_pcm16({-1.0})[0], -32768);
    EXPECT_EQ(pipeline::quantize_pcm16({1.0})[0], 32767);
}

namespace {

// The displacement impulse response of a simulated plate (scenes/test-small.toml,
// lossy acrylic, clamped) from a point force to a point, at `rate`, peak 1.
std::vector<double> simulated_plate_ir(double rate, double duration_s)
{
    const scene::Scene sc = scene::load_scene(std::string(HAPTIC_SOURCE_DIR) + "/scenes/test-small.toml");
    const scene::PlateSetup setup = scene::build_plate(sc);
    engine::SimulationOptions o = setup.options;
    o.engine.threads = 1;
    engine::Simulation sim(setup.plate, o);
    sim.set_source_impulse(sim.add_source(0.061, 0.047));
    sim.add_receiver(0.213, 0.128);
    sim.run(sim.steps_for(duration_s));
    std::vector<double> h = pipeline::resample(sim.traces()[0], 1 / sim.time_step_s(), rate);
    h.resize(static_cast<std::size_t>(std::llround(duration_s * rate)));
    double peak = 0;
    for (double v : h)
        peak = std::max(peak, std::abs(v));
    for (double &v : h)
        v /= peak;
    return h;
}

std::vector<double> convolve(const std::vector<double> &a, const std::vector<double> &b)
{
    std::vector<double> y(a.size() + b.size() - 1, 0.0);
    for (std::size_t i = 0; i < a.size(); i++)
        if (a[i] != 0)
            for (std::size_t j = 0; j < b.size(); j++)
                y[i + j] += a[i] * b[j];
    return y;
}

// IFFT_N(W FFT_N(x)), first `length` samples: x band-limited as the deconvolution does.
std::vector<double> band_limited(const std::vector<double> &x, std::size_t N, std::size_t length, double f_lo,
                                 double f_hi, double rate)
{
    pipeline::RealFft fft(N);
    fft.forward_padded(x.data(), x.size());
    for (std::size_t k = 0; k < fft.bins(); k++)
        fft.spectrum()[k] *= pipeline::deconvolution_taper(double(k) * rate / double(N), f_lo, f_hi);
    fft.inverse();
    std::vector<double> y(fft.real(), fft.real() + length);
    for (double &v : y)
        v /= double(N);
    return y;
}

double energy(const std::vector<double> &x)
{
    double e = 0;
    for (double v : x)
        e += v * v;
    return e;
}

} // namespace

// A simulated plate's impulse response h, recorded through the plan's
// quantised sweep with white noise added at a 30 dB recording SNR: the
// deconvolved response equals h band-limited by the taper, and what differs
// is the noise through the inverse filter, whose energy over the kept
// samples is predicted exactly from the excitation:
//   E|e[t]|^2 = sigma^2 sum_{j < n} g[t - j]^2,  g = IFFT(W conj(X) / (|X|^2 + eps))
// (white noise of variance sigma^2 over the n recorded samples, through the
// linear filter g). The measured energy lies within a factor 1.5 of the
// prediction either way (the estimate's own scatter over 4000 correlated
// samples is some 10 %); a response one sample off misses by some 18 dB.
TEST(Deconvolution, RecoversASimulatedPlateWithinTheNoisePrediction)
{
    const double rate = 16000;
    const std::vector<double> h = simulated_plate_ir(rate, 0.25); // 4000 samples, about 70 dB of decay at 100 Hz
    SweepSpec s;
    s.f1_hz = 50;
    s.f2_hz = 3000;
    s.duration_s = 1;
    s.rate_hz = rate;
    s.amplitude = 0.5;
    const std::vector<int16_t> q = pipeline::quantize_pcm16(pipeline::exponential_sweep(s));
    const pipeline::PlanLayout layout = pipeline::plan_layout(2, 800, q.size(), 4800);
    const std::vector<int16_t> plan = pipeline::plan_samples(layout, q);
    // Exciter 1's excitation, exactly as played (count / 32768, as a reader gets it back).
    const std::size_t m = layout.sweep_frames, n = layout.sweep_frames + layout.gap_frames;
    std::vector<double> x(m);
    for (std::size_t i = 0; i < m; i++)
        x[i] = plan[(layout.start_frames[1] + i) * 2 + 1] / 32768.0;
    std::vector<double> clean = convolve(x, h);
    clean.resize(n, 0.0); // the segment: the sweep and the decay after it (h ends before the gap does)
    const double recording_snr_db = 30;
    const double sigma = std::sqrt(energy(clean) / double(m + h.size()) / std::pow(10.0, recording_snr_db / 10));
    std::mt19937_64 rng(25);
    std::normal_distribution<double> noise(0, sigma);
    std::vector<double> rec = clean;
    for (double &v : rec)
        v += noise(rng);

    const std::size_t L = h.size();
    const std::vector<double> est = pipeline::impulse_response(rec.data(), n, x.data(), m, L, s.f1_hz, s.f2_hz, rate);
    ASSERT_EQ(est.size(), L);
    const std::size_t N = pipeline::deconvolution_fft_size(n + m);
    const std::vector<double> ref = band_limited(h, N, L, s.f1_hz, s.f2_hz, rate);

    // Noiseless: the regularisation's bias stays far below the noise.
    const std::vector<double> exact =
        pipeline::impulse_response(clean.data(), n, x.data(), m, L, s.f1_hz, s.f2_hz, rate);
    std::vector<double> bias(L);
    for (std::size_t i = 0; i < L; i++)
        bias[i] = exact[i] - ref[i];
    EXPECT_LT(10 * std::log10(energy(bias) / energy(ref)), -80);

    // The noise's prediction: g, the inverse filter, then the sum over the recorded lags.
    std::vector<double> g2(N);
    {
        pipeline::RealFft fft(N);
        fft.forward_padded(x.data(), m);
        double peak = 0;
        for (std::size_t k = 0; k < fft.bins(); k++) {
            const double f = double(k) * rate / double(N);
            if (f >= s.f1_hz && f <= s.f2_hz)
                peak = std::max(peak, std::norm(fft.spectrum()[k]));
        }
        for (std::size_t k = 0; k < fft.bins(); k++) {
            const std::complex<double> X = fft.spectrum()[k];
            fft.spectrum()[k] = pipeline::deconvolution_taper(double(k) * rate / double(N), s.f1_hz, s.f2_hz) *
                                std::conj(X) / (std::norm(X) + 1e-6 * peak);
        }
        fft.inverse();
        for (std::size_t i = 0; i < N; i++)
            g2[i] = std::pow(fft.real()[i] / double(N), 2);
    }
    double predicted = 0;
    for (std::size_t t = 0; t < L; t++)
        for (std::size_t j = 0; j < n; j++)
            predicted += g2[(t + N - j) % N];
    predicted *= sigma * sigma;
    std::vector<double> err(L);
    for (std::size_t i = 0; i < L; i++)
        err[i] = est[i] - ref[i];
    const double measured = energy(err);
    const double ratio_db = 10 * std::log10(measured / predicted);
    double peak = 0;
    for (double v : ref)
        peak = std::max(peak, v * v);
    std::printf("deconvolution: error %.2f dB from the noise's prediction; response energy over the error's %.1f dB, "
                "peak over the noise floor %.1f dB (recording %.0f dB over the whole band)\n",
                ratio_db, 10 * std::log10(energy(ref) / measured), 10 * std::log10(peak * double(L) / measured),
                recording_snr_db);
    EXPECT_LT(std::abs(ratio_db), 10 * std::log10(1.5));
    // And a deconvolution off by one sample is far outside it.
    std::vector<double> shifted(L, 0.0);
    for (std::size_t i = 1; i < L; i++)
        shifted[i] = ref[i - 1];
    for (std::size_t i = 0; i < L; i++)
        err[i] = est[i] - shifted[i];
    EXPECT_GT(10 * std::log10(energy(err) / predicted), 10);
}

// The plan's SNR rule (sweep.h): a system that is an impulse (delayed), white
// noise on the recording; the deconvolved response's peak over its noise
// floor (RMS over the kept samples) is the recording's SNR in the band plus
// 10 log10(T B), within 1 dB (an exponential sweep's pink spectrum loses
// 10 log10(ln(f2 / f1) / 2) of the flat sweep's 10 log10(2 T B): -0.2 dB here).
TEST(Deconvolution, SnrRuleHoldsForAnImpulse)
{
    const double rate = 16000;
    SweepSpec s;
    s.f1_hz = 50;
    s.f2_hz = 3000;
    s.duration_s = 1;
    s.rate_hz = rate;
    s.amplitude = 0.5;
    const std::vector<int16_t> q = pipeline::quantize_pcm16(pipeline::exponential_sweep(s));
    std::vector<double> x(q.size());
    for (std::size_t i = 0; i < q.size(); i++)
        x[i] = q[i] / 32768.0;
    const std::size_t m = x.size(), n = m + 4800, L = 4000, delay = 100;
    const double sigma = 0.01;
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0, sigma);
    std::vector<double> rec(n, 0.0), h(L, 0.0);
    h[delay] = 1;
    for (std::size_t i = 0; i < n; i++)
        rec[i] = (i >= delay && i - delay < m ? x[i - delay] : 0.0) + noise(rng);
    const double band_fraction = 2 * (s.f2_hz - s.f1_hz) / rate; // of the noise's power, in the band
    const double recording_snr_db = 10 * std::log10(energy(x) / double(m) / (sigma * sigma * band_fraction));
    const std::vector<double> est = pipeline::impulse_response(rec.data(), n, x.data(), m, L, s.f1_hz, s.f2_hz, rate);
    const std::vector<double> ref = band_limited(h, pipeline::deconvolution_fft_size(n + m), L, s.f1_hz, s.f2_hz, rate);
    std::vector<double> err(L);
    for (std::size_t i = 0; i < L; i++)
        err[i] = est[i] - ref[i];
    const double peak_snr_db = 10 * std::log10(ref[delay] * ref[delay] / (energy(err) / double(L)));
    const double rule_db = pipeline::deconvolved_snr_db(recording_snr_db, s.duration_s, s.f2_hz - s.f1_hz);
    std::printf("SNR rule: recording %.1f dB in the band, response peak %.1f dB over its floor, rule %.1f dB\n",
                recording_snr_db, peak_snr_db, rule_db);
    EXPECT_NEAR(peak_snr_db, rule_db, 1.0);
}

// Where the excitation has no energy inside the band (x = [1, 0, 1]: a null
// at a quarter of the rate) the regularisation keeps the estimate finite and
// bounded instead of dividing noise by zero.
TEST(Deconvolution, ANullInTheExcitationStaysBounded)
{
    const std::vector<double> x{1, 0, 1};
    std::vector<double> rec(64, 0.0);
    std::mt19937_64 rng(3);
    std::normal_distribution<double> noise(0, 1e-3);
    rec[0] = 1;
    rec[2] = 1; // h = delta
    for (double &v : rec)
        v += noise(rng);
    const std::vector<double> est =
        pipeline::impulse_response(rec.data(), rec.size(), x.data(), x.size(), 32, 1000, 4500, 10000);
    double peak = 0;
    for (double v : est) {
        ASSERT_TRUE(std::isfinite(v));
        peak = std::max(peak, std::abs(v));
    }
    EXPECT_LT(peak, 10.0);
}

TEST(Deconvolution, RefusesWhatItCannotDo)
{
    const std::vector<double> x(100, 0.0), r(200, 0.0);
    EXPECT_THROW(pipeline::impulse_response(r.data(), 200, x.data(), 100, 50, 100, 2000, 8000), std::invalid_argument);
    std::vector<double> y(100, 0.0);
    y[0] = 1;
    EXPECT_THROW(pipeline::impulse_response(r.data(), 200, y.data(), 100, 300, 100, 2000, 8000), std::invalid_argument);
    EXPECT_THROW(pipeline::impulse_response(r.data(), 200, y.data(), 100, 50, 100, 5000, 8000), std::invalid_argument);
    EXPECT_NO_THROW(pipeline::impulse_response(r.data(), 200, y.data(), 100, 50, 100, 2000, 8000));
}
