// What a drive costs and what a listener hears, against hand computations
// and closed forms: the force energy and out-of-band fraction of tones, a
// small baffled piston's pressure on axis (Rayleigh), IEC 61672-1's
// A-weighting table and a tone's exposure.
#include "pipeline/verification/drive_figures.h"
#include "pipeline/verification/radiation.h"
#include "pipeline/signal/pulse.h"
#include "scene/calibration_input.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "scene_text.h"

using namespace calib;

TEST(DriveFigures, DriveEnergyAndOutOfBandFractionOfHandComputedSignals)
{
    const pipeline::CalibrationInput in = scene::calibration_input(scene_text::load("inverse.toml"), "inverse.toml");
    const double rate = 48000, edge = pipeline::pulse_max_frequency_hz(in.pulse);
    const unsigned C = 2;
    const std::size_t n = 4800; // 0.1 s: whole periods of both tones below
    // Channel 0: 1200 Hz (in band) at 10000 counts; channel 1: silent, then a tone above the band.
    const double f_hi = 480 * std::ceil(1.5 * edge / 480);
    std::vector<int16_t> s(n * C, 0);
    for (std::size_t i = 0; i < n; i++) {
        s[i * C] = static_cast<int16_t>(std::lround(10000 * std::sin(2 * std::numbers::pi * 1200 * double(i) / rate)));
        s[i * C + 1] =
            static_cast<int16_t>(std::lround(5000 * std::sin(2 * std::numbers::pi * f_hi * double(i) / rate)));
    }
    const pipeline::DriveFigures d = pipeline::drive_figures(in, s, C, rate, 2e-6);
    const double F = 0.5 / 32767; // N per count
    const double e0 = 0.5 * (10000 * F) * (10000 * F) * 0.1, e1 = 0.5 * (5000 * F) * (5000 * F) * 0.1;
    EXPECT_NEAR(d.energy_n2s, e0 + e1, 1e-3 * (e0 + e1)); // rounding to counts only
    EXPECT_NEAR(d.out_of_band_fraction, e1 / (e0 + e1), 1e-3);
    EXPECT_NEAR(d.peak_per_root_energy, 2e-6 / std::sqrt(e0 + e1), 1e-3 * 2e-6 / std::sqrt(e0 + e1));

    // A prime length (4801 frames) and an even one without the tones' whole
    // periods: the spectrum's energy is the samples' (Parseval), to round-off.
    for (const std::size_t m : {std::size_t(4801), std::size_t(4798)}) {
        SCOPED_TRACE("frames " + std::to_string(m));
        std::vector<int16_t> odd(m * C);
        for (std::size_t i = 0; i < m * C; i++)
            odd[i] = s[i % (n * C)] ^ int16_t(i % 7);
        const double want = pipeline::drive_energy_n2s(odd, in.exciters.force_full_scale_n, rate);
        EXPECT_NEAR(pipeline::drive_figures(in, odd, C, rate, 2e-6).energy_n2s, want, 1e-12 * want);
    }
    // One frame: no spectrum to take, its energy all the same.
    const std::vector<int16_t> one = {1000, -2000};
    const pipeline::DriveFigures d1 = pipeline::drive_figures(in, one, C, rate, 2e-6);
    EXPECT_DOUBLE_EQ(d1.energy_n2s, pipeline::drive_energy_n2s(one, in.exciters.force_full_scale_n, rate));
    EXPECT_EQ(d1.out_of_band_fraction, 0.0);
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
    EXPECT_LT(diff, 0.01 * peak); // float field, path differences of 0.04 mm over the patch

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
