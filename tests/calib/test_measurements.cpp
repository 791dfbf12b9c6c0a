// The bench's plan and measurements.toml (docs/bench.md, "The plan and
// measurements.toml"): what measure-plan chooses from a scene (band, length,
// gap, layout) by its stated rules; the reader gives back what the plan wrote
// and refuses every defect of the contract in one line naming the file and
// the key.
#include "engine/plate_operator.h"
#include "io/atomic_file.h"
#include "pipeline/signal/pulse.h"
#include "scene/measurement_plan.h"
#include "scene/measurements.h"
#include "scene/scene.h"
#include "scene/toml_fields.h"
#include "scene/wav_file.h"
#include "scene_text.h"

#include <gtest/gtest.h>
#include <unistd.h>
#include <sndfile.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

using namespace calib;
using scene_text::replace;

namespace {

const std::string inverse_text = scene_text::load("inverse.toml"); // 4 fixed exciters, lossy, 0.30 x 0.24 m

scene::Scene inverse_scene(const std::string &text = inverse_text) { return scene::parse_scene(text, "scene.toml"); }

scene::MeasurementPlan plan_of(const scene::Scene &s, scene::PlanOptions o = {})
{
    return scene::plan_measurement(s, s.exciters->positions, o);
}

std::string plan_error(const scene::Scene &s, const scene::PlanOptions &o)
{
    try {
        plan_of(s, o);
    } catch (const std::exception &e) {
        return e.what();
    }
    return "";
}

} // namespace

// inverse.toml's pulse (2-cycle Hann burst at 1.2 kHz): hi = its -40 dB top,
// lo = max(2 x 1200 - hi, 300) = 300 Hz; the sweep from lo / 2 to 1.5 hi.
// Both length rules ask less than a second: the 1 s minimum. The gap: the
// loss law's 60 dB at 150 Hz, x1.25 + 50 ms, in whole 10 ms.
TEST(MeasurementPlan, ChoosesBandLengthAndGapByTheStatedRules)
{
    const scene::Scene s = inverse_scene();
    const scene::MeasurementPlan p = plan_of(s);
    const double hi = pipeline::pulse_max_frequency_hz(*s.pulse);
    EXPECT_NEAR(p.pulse_hi_hz, hi, 1e-9);
    EXPECT_NEAR(p.pulse_lo_hz, 300, 1e-9);
    EXPECT_NEAR(p.sweep.f1_hz, 150, 1e-9);
    EXPECT_NEAR(p.sweep.f2_hz, 1.5 * hi, 1e-9);
    EXPECT_EQ(p.sweep.rate_hz, 48000);
    EXPECT_EQ(p.sweep.duration_s, 1.0);
    EXPECT_EQ(p.length_rule, "the 1 s minimum");
    EXPECT_NEAR(p.sweep.amplitude, std::pow(10.0, -6.0 / 20), 1e-12);
    const double kappa = s.plate.material.kappa(s.plate.thickness_m);
    const engine::Loss loss = engine::loss_from_t60(kappa, 400, 0.135, 1200, 0.045);
    const double sigma = loss.decay_rate_1_s(2 * std::numbers::pi * 150, kappa);
    EXPECT_NEAR(p.decay_f1_s, 3 * std::log(10.0) / sigma, 1e-9);
    EXPECT_GE(p.gap_s, 1.25 * p.decay_f1_s + 0.05 - 1e-9);
    EXPECT_LT(p.gap_s, 1.25 * p.decay_f1_s + 0.06);
    EXPECT_NEAR(p.gap_s * 100, std::round(p.gap_s * 100), 1e-9);
    ASSERT_EQ(p.layout.channels, 4u);
    const std::size_t gap = static_cast<std::size_t>(std::llround(p.gap_s * 48000));
    for (std::size_t c = 0; c < 4; c++)
        EXPECT_EQ(p.layout.start_frames[c], 12000 + c * (48000 + gap));
    EXPECT_NEAR(p.total_s(), 0.25 + 4 * (1 + p.gap_s), 1e-9);
    EXPECT_GE(p.predicted_snr_db, 60);
    EXPECT_EQ(p.force_full_scale_n, 0.5);
}

TEST(MeasurementPlan, LengthFromTheSnrRuleAndItsCap)
{
    const scene::Scene s = inverse_scene();
    scene::PlanOptions o;
    o.recording_snr_db = 10; // 60 dB needs T B = 1e5: 24.1 s over 4.15 kHz
    scene::MeasurementPlan p = plan_of(s, o);
    const double B = p.sweep.f2_hz - p.sweep.f1_hz;
    EXPECT_NEAR(p.sweep.duration_s, std::ceil(1e5 / B * 100) / 100, 1e-9);
    EXPECT_NE(p.length_rule.find("the SNR rule"), std::string::npos) << p.length_rule;
    EXPECT_GE(p.predicted_snr_db, 60);
    o.recording_snr_db = 0; // 241 s wanted: cut at 30 s, and said so
    p = plan_of(s, o);
    EXPECT_EQ(p.sweep.duration_s, 30);
    EXPECT_NE(p.length_rule.find("the 30 s maximum: the deconvolved SNR reaches only 51 dB"), std::string::npos)
        << p.length_rule;
}

TEST(MeasurementPlan, RefusesWhatItCannotPlan)
{
    const scene::Scene s = inverse_scene();
    scene::PlanOptions o;
    o.rate_hz = 8000; // 0.45 x 8 kHz = 3.6 kHz: not a third of an octave past the 2.87 kHz top
    EXPECT_NE(plan_error(s, o).find("--rate: 8000 Hz cannot carry a sweep a third of an octave past the pulse's band "
                                    "top 2866 Hz"),
              std::string::npos)
        << plan_error(s, o);
    o = {};
    o.level_dbfs = 1;
    EXPECT_EQ(plan_error(s, o), "--level-dbfs: must lie in [-60, 0), got 1");
    const scene::Scene lossless = inverse_scene(
        replace(inverse_text, "[plate.loss]\nfrequencies_hz = [400, 1200]\nt60_s = [0.135, 0.045]\n", ""));
    EXPECT_NE(plan_error(lossless, {}).find("scene.toml: plate.loss: missing"), std::string::npos);
    std::vector<pipeline::Point> off = s.exciters->positions;
    off[2].x_m = 0.31;
    o = {};
    o.positions_from = "t.htab";
    try {
        scene::plan_measurement(s, off, o);
        ADD_FAILURE() << "an exciter off the plate was accepted";
    } catch (const std::invalid_argument &e) {
        EXPECT_EQ(std::string(e.what()), "t.htab: exciter 2 at (0.31, 0.024) m is off the 0.3 x 0.24 m plate");
    }
}

namespace {

namespace fs = std::filesystem;

// A float WAV of `channels` channels and `frames` frames at `rate`, sample (n, c) = f(n, c).
template <class F>
void write_float_wav(const fs::path &path, int channels, std::size_t frames, int rate, F f)
{
    SF_INFO info{};
    info.samplerate = rate;
    info.channels = channels;
    info.format = SF_FORMAT_WAV | SF_FORMAT_FLOAT;
    SNDFILE *snd = sf_open(path.c_str(), SFM_WRITE, &info);
    ASSERT_NE(snd, nullptr) << sf_strerror(nullptr);
    std::vector<double> x(frames * std::size_t(channels));
    for (std::size_t n = 0; n < frames; n++)
        for (int c = 0; c < channels; c++)
            x[n * std::size_t(channels) + std::size_t(c)] = f(n, c);
    sf_writef_double(snd, x.data(), sf_count_t(frames));
    sf_close(snd);
}

const char *sensors = R"(
[[sensor]]
position_m = [0.15, 0.12]
channel = 0
quantity = "acceleration"
units_per_count = 0.025

[[sensor]]
position_m = [0.1, 0.2]
channel = 1
quantity = "velocity"
)";

// A directory with the plan of inverse.toml at 16 kHz (plan.wav and its
// measurements.toml text) and recordings: rec.wav (3 channels: two sines and
// a silent one), rec8k.wav (another rate), short.wav (too short), clipped.wav.
class Measurements : public ::testing::Test {
  protected:
    void SetUp() override
    {
        // One directory per process: ctest runs this fixture's tests as
        // separate processes side by side, and a shared one was emptied by
        // one test's SetUp under another.
        dir = fs::path(::testing::TempDir()) / ("measurements_test-" + std::to_string(::getpid()));
        fs::remove_all(dir);
        fs::create_directories(dir);
        scene::PlanOptions o;
        o.rate_hz = 16000;
        plan = plan_of(sc, o);
        io::write_file_atomic((dir / "plan.wav").string(), scene::wav_pcm16_bytes(scene::plan_pcm16(plan), 4, 16000));
        text = scene::measurements_toml(plan, "plan.wav", "scene.toml", "crc32:0", "calibgen measure-plan") + sensors;
        const std::size_t frames = plan.layout.total_frames;
        auto sines = [](std::size_t n, int c) {
            return c == 2 ? 0.0 : 0.1 * (c + 1) * std::sin(0.05 * double(n) * (c + 1));
        };
        write_float_wav(dir / "rec.wav", 3, frames, 16000, sines);
        write_float_wav(dir / "rec8k.wav", 3, frames, 8000, sines);
        write_float_wav(dir / "short.wav", 3, frames - 1, 16000, sines);
        write_float_wav(dir / "clipped.wav", 3, frames, 16000,
                        [&](std::size_t n, int c) { return c == 0 && n >= 1000 && n < 1010 ? 1.0 : sines(n, c); });
    }

    void TearDown() override { fs::remove_all(dir); }

    // The one-line error of loading `t` as m.toml ("" if none).
    std::string error_of(const std::string &t, const scene::Scene &s)
    {
        io::write_file_atomic((dir / "m.toml").string(), t);
        try {
            scene::load_measurements((dir / "m.toml").string(), s);
        } catch (const scene::SceneError &e) {
            const std::string what = e.what();
            EXPECT_EQ(what.find('\n'), std::string::npos) << what;
            EXPECT_EQ(what.rfind((dir / "m.toml").string() + ": ", 0), 0u) << what;
            return what.substr((dir / "m.toml").string().size() + 2);
        }
        return "";
    }
    std::string error_of(const std::string &t) { return error_of(t, sc); }

    scene::Scene sc = inverse_scene();
    scene::MeasurementPlan plan;
    fs::path dir;
    std::string text;
};

} // namespace

// What the plan wrote comes back: the keys, the plan's samples as played
// (count / 32768), the recording, the sensors; file names resolve against
// the toml's directory.
TEST_F(Measurements, ReadsBackWhatThePlanWrote)
{
    ASSERT_EQ(error_of(text), "");
    const scene::Measurements m = scene::load_measurements((dir / "m.toml").string(), sc);
    EXPECT_EQ(m.scene, "scene.toml");
    EXPECT_EQ(m.rate_hz, 16000);
    EXPECT_EQ(m.start_frames, plan.layout.start_frames);
    EXPECT_EQ(m.sweep_frames(), plan.layout.sweep_frames);
    EXPECT_EQ(m.segment_frames(), plan.layout.sweep_frames + plan.layout.gap_frames);
    EXPECT_NEAR(m.sweep_f1_hz, 150, 1e-6);
    EXPECT_EQ(m.plan.channels, 4u);
    EXPECT_EQ(m.plan.frames, plan.layout.total_frames);
    EXPECT_EQ(fs::path(m.plan_path), dir / "plan.wav");
    EXPECT_EQ(fs::path(m.recording_path), dir / "rec.wav");
    ASSERT_EQ(m.exciters.size(), 4u);
    EXPECT_EQ(m.exciters[1].x_m, 0.273);
    EXPECT_EQ(m.force_full_scale_n, 0.5);
    const std::vector<int16_t> q =
        pipeline::quantize_pcm16(pipeline::exponential_sweep(plan.sweep)); // what the plan plays
    for (std::size_t e = 0; e < 4; e++) {
        const std::vector<double> x = m.excitation(e);
        ASSERT_EQ(x.size(), q.size());
        for (std::size_t i = 0; i < q.size(); i++)
            ASSERT_EQ(x[i], q[i] / 32768.0) << "exciter " << e << " sample " << i;
    }
    ASSERT_EQ(m.sensors.size(), 2u);
    EXPECT_EQ(m.sensors[0].quantity, scene::SensorQuantity::acceleration);
    EXPECT_EQ(*m.sensors[0].units_per_count, 0.025);
    EXPECT_EQ(m.sensors[1].quantity, scene::SensorQuantity::velocity);
    EXPECT_FALSE(m.sensors[1].units_per_count);
    EXPECT_EQ(m.sensors[1].at.y_m, 0.2);
    const std::vector<double> seg = m.segment(1, 2);
    ASSERT_EQ(seg.size(), m.segment_frames());
    EXPECT_NEAR(seg[5], 0.2 * std::sin(0.1 * double(m.start_frames[2] + 5)), 1e-7);
}

TEST_F(Measurements, RefusesEachDefectInOneLineNamingTheKey)
{
    // A sensor off the plate.
    EXPECT_EQ(error_of(replace(text, "position_m = [0.15, 0.12]", "position_m = [0.5, 0.12]")),
              "sensor[0].position_m: (0.5, 0.12) m is off the 0.3 x 0.24 m plate");
    // The plan's WAV at another rate than the key says.
    EXPECT_EQ(error_of(replace(text, "rate_hz = 16000", "rate_hz = 48000")),
              "excitation.rate_hz: 48000 but plan.wav is at 16000 Hz");
    // The recording at another rate than the plan.
    EXPECT_EQ(error_of(replace(text, "file = \"rec.wav\"", "file = \"rec8k.wav\"")),
              "recording.file: rec8k.wav is at 8000 Hz but plan.wav at 16000 Hz");
    // The recording shorter than the plan.
    EXPECT_EQ(error_of(replace(text, "file = \"rec.wav\"", "file = \"short.wav\"")),
              "recording.file: short.wav has " + std::to_string(plan.layout.total_frames - 1) +
                  " frames, shorter than plan.wav's " + std::to_string(plan.layout.total_frames));
    // A channel the recording does not have.
    EXPECT_EQ(error_of(replace(text, "channel = 1", "channel = 5")), "sensor[1].channel: 5 but rec.wav has 3 channels");
    // A channel of silence; a clipped one.
    EXPECT_EQ(error_of(replace(text, "channel = 1", "channel = 2")),
              "sensor[1].channel: channel 2 of rec.wav is silence (peak below one 16-bit count)");
    EXPECT_EQ(error_of(replace(text, "file = \"rec.wav\"", "file = \"clipped.wav\"")),
              "sensor[0].channel: channel 0 of clipped.wav is clipped (10 samples at 0.999 of full scale or beyond)");
    // The plan's channels against the scene's exciters.
    const scene::Scene three =
        inverse_scene(replace(replace(inverse_text, "count = 4", "count = 3"), ", [0.035, 0.221]]", "]"));
    EXPECT_EQ(error_of(text, three), "excitation.file: plan.wav has 4 channels but scene.toml has 3 exciters");
    // Unknown keys, at the top, in a section, in a sensor.
    EXPECT_EQ(error_of("gain = 2\n" + text),
              "gain: unknown key (known: scene, excitation, exciters, recording, sensor)");
    EXPECT_EQ(error_of(replace(text, "[recording]\n", "[recording]\nformat = \"s16\"\n")),
              "recording.format: unknown key (known: file)");
    EXPECT_EQ(error_of(replace(text, "channel = 0\n", "channel = 0\nsensitivity = 3\n")),
              "sensor[0].sensitivity: unknown key (known: position_m, channel, quantity, units_per_count)");
    // A quantity that is none of the three.
    EXPECT_EQ(error_of(replace(text, "quantity = \"velocity\"", "quantity = \"pressure\"")),
              "sensor[1].quantity: unknown quantity \"pressure\" (known: displacement, velocity, acceleration)");
    // Missing files.
    EXPECT_EQ(error_of(replace(text, "file = \"rec.wav\"", "file = \"nothere.wav\""))
                  .rfind("recording.file: cannot read nothere.wav: ", 0),
              0u);
    EXPECT_EQ(error_of(replace(text, "file = \"plan.wav\"", "file = \"noplan.wav\""))
                  .rfind("excitation.file: cannot read noplan.wav: ", 0),
              0u);
    // And more the contract implies: two sensors on one channel, no sensor,
    // a sweep past the plan's end, positions not one per exciter, a units
    // value that is no gain.
    EXPECT_EQ(error_of(replace(text, "channel = 1", "channel = 0")), "sensor[1].channel: 0 is sensor[0]'s channel too");
    EXPECT_EQ(error_of(text.substr(0, text.find("\n[[sensor]]"))),
              "sensor: missing: one [[sensor]] table per recorded sensor (position_m, channel, quantity)");
    const std::string last = std::to_string(plan.layout.start_frames[3]);
    EXPECT_EQ(error_of(replace(text, ", " + last + "]", ", " + std::to_string(plan.layout.start_frames[3] + 1) + "]")),
              "excitation.start_frames: entry 3: " + std::to_string(plan.layout.start_frames[3] + 1) + " + " +
                  std::to_string(plan.layout.sweep_frames + plan.layout.gap_frames) +
                  " frames (sweep_s and gap_s) run past the end of plan.wav (" +
                  std::to_string(plan.layout.total_frames) + " frames)");
    EXPECT_EQ(error_of(replace(text, ", [0.035, 0.221]]", "]")), "exciters.positions_m: 3 positions for 4 exciters");
    EXPECT_EQ(error_of(replace(text, "units_per_count = 0.025", "units_per_count = -1")),
              "sensor[0].units_per_count: must be > 0, got -1");
}

TEST_F(Measurements, AMissingTomlIsOneLine)
{
    try {
        scene::load_measurements((dir / "none.toml").string(), sc);
        ADD_FAILURE() << "a missing file was accepted";
    } catch (const scene::SceneError &e) {
        EXPECT_EQ(std::string(e.what()), (dir / "none.toml").string() + ": cannot open measurements file");
    }
}
