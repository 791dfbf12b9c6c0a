#include "pipeline/bench/bench_synth.h"

#include "engine/simulation.h"
#include "pipeline/signal/real_fft.h"
#include "pipeline/signal/resample.h"
#include "pipeline/transfer/transfer.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

SyntheticRecording synthesize_recording(const CalibrationInput &truth, const std::vector<BenchSensor> &sensors,
                                        const std::vector<std::optional<double>> &units_per_count,
                                        const std::vector<std::vector<double>> &plan, double rate_hz, double response_s,
                                        double f_max_hz, double noise_db, uint64_t seed, const ProgressFn &progress)
{
    const std::vector<Point> &exciters = truth.exciters.positions;
    if (exciters.empty() || exciters.size() != plan.size())
        throw std::invalid_argument("synthetic bench: the plate's scene needs placement = \"fixed\" with one "
                                    "position per plan channel (" +
                                    std::to_string(plan.size()) + ")");
    if (sensors.size() != units_per_count.size() || sensors.empty())
        throw std::invalid_argument("synthetic bench: no sensor");
    const std::size_t frames = plan[0].size();

    // The plate's responses exciter -> sensor (with the scene's force gains).
    engine::Simulation probe(truth.plate, single_core_options(truth));
    const double k = probe.time_step_s();
    TransferOptions o;
    o.decimation = std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(1.0 / (k * 3 * f_max_hz))));
    const double sim_rate = 1.0 / (double(o.decimation) * k);
    o.samples = static_cast<std::size_t>(std::ceil(response_s * sim_rate)) + 1;
    o.stop_hz = 0.5 * sim_rate;
    o.pass_hz = std::min(1.1 * f_max_hz, 0.75 * o.stop_hz);
    std::vector<Point> points;
    for (const BenchSensor &s : sensors)
        points.push_back(s.at);
    TransferMatrix H = simulate_transfer(truth, exciters, points, o, [&](std::size_t done, std::size_t total) {
        if (progress)
            progress("synthetic bench", done, total);
    });
    apply_force_gains(truth, H);

    // rec_s = sum_e x_e * (F / rate) d^q/dt^q H_se, by FFT over the whole plan.
    const std::size_t ir = static_cast<std::size_t>(std::ceil(response_s * rate_hz));
    std::size_t n = 1;
    while (n < frames + ir)
        n <<= 1;
    RealFft fft(n);
    std::vector<std::vector<std::complex<double>>> X(plan.size());
    for (std::size_t c = 0; c < plan.size(); c++) {
        fft.forward_padded(plan[c].data(), plan[c].size());
        X[c].assign(fft.spectrum(), fft.spectrum() + fft.bins());
    }
    SyntheticRecording out;
    const double F = truth.exciters.force_full_scale_n;
    std::vector<bool> sweeping(frames, false);
    for (const std::vector<double> &ch : plan)
        for (std::size_t i = 0; i < frames; i++)
            sweeping[i] = sweeping[i] || ch[i] != 0;
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    for (std::size_t s = 0; s < sensors.size(); s++) {
        std::vector<std::complex<double>> R(fft.bins(), 0.0);
        for (std::size_t c = 0; c < plan.size(); c++) {
            const float *h = H.response(c, H.exact_begin() + s);
            std::vector<double> hs = resample(std::vector<double>(h, h + H.samples), H.rate_hz, rate_hz);
            hs.resize(std::min(hs.size(), ir));
            fft.forward_padded(hs.data(), hs.size());
            for (std::size_t b = 0; b < fft.bins(); b++)
                R[b] += X[c][b] * fft.spectrum()[b];
        }
        const int q = int(sensors[s].quantity);
        for (std::size_t b = 0; b < fft.bins(); b++) {
            const std::complex<double> jw(0, 2 * std::numbers::pi * double(b) * rate_hz / double(n));
            std::complex<double> d = F / rate_hz / double(n);
            for (int i = 0; i < q; i++)
                d *= jw;
            fft.spectrum()[b] = R[b] * d;
        }
        fft.inverse();
        std::vector<double> y(fft.real(), fft.real() + frames);
        double peak = 0, e = 0;
        std::size_t count = 0;
        for (std::size_t i = 0; i < frames; i++) {
            peak = std::max(peak, std::abs(y[i]));
            if (sweeping[i])
                e += y[i] * y[i], count++;
        }
        const double u = units_per_count[s] ? *units_per_count[s] : (peak > 0 ? peak / 0.5 : 1.0);
        const double noise = std::sqrt(e / double(std::max<std::size_t>(count, 1))) / u * std::pow(10, noise_db / 20);
        for (double &v : y)
            v = v / u + noise * normal(rng);
        out.channels.push_back(std::move(y));
        out.units_per_count.push_back(u);
        out.noise_rms.push_back(noise);
    }
    return out;
}

} // namespace calib::pipeline
