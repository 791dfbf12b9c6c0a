#include "scene/measurements.h"

#include "scene/toml_fields.h"

#include "io/read_file.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

namespace calib::scene {

std::size_t Measurements::sweep_frames() const { return static_cast<std::size_t>(std::llround(sweep_s * rate_hz)); }

std::size_t Measurements::segment_frames() const
{
    return static_cast<std::size_t>(std::llround((sweep_s + gap_s) * rate_hz));
}

std::vector<double> Measurements::excitation(std::size_t e) const
{
    return plan.channel(e, start_frames.at(e), sweep_frames());
}

std::vector<double> Measurements::segment(std::size_t s, std::size_t e) const
{
    return recording.channel(sensors.at(s).channel, start_frames.at(e), segment_frames());
}

namespace {

bool on_plate(const Scene &scene, const pipeline::Point &p)
{
    return p.x_m >= 0 && p.x_m <= scene.plate.size_x_m && p.y_m >= 0 && p.y_m <= scene.plate.size_y_m;
}

std::string plate_words(const Scene &scene)
{
    return "the " + format_number(scene.plate.size_x_m) + " x " + format_number(scene.plate.size_y_m) + " m plate";
}

std::string point_words(const pipeline::Point &p)
{
    return "(" + format_number(p.x_m) + ", " + format_number(p.y_m) + ") m";
}

std::vector<pipeline::Point> positions(const Fields &f, std::string_view key)
{
    const toml::node *n = f.node(key);
    const toml::array *a = n ? n->as_array() : nullptr;
    if (!n)
        f.fail(key, "missing (required): [[x, y], ...] in metres, one per exciter");
    if (!a)
        f.fail(key, "must be an array of [x, y] pairs in metres");
    std::vector<pipeline::Point> pts;
    for (std::size_t i = 0; i < a->size(); i++) {
        const toml::array *p = (*a)[i].as_array();
        std::optional<double> xy[2];
        if (p && p->size() == 2)
            for (std::size_t k = 0; k < 2; k++)
                xy[k] = (*p)[k].value<double>();
        if (!xy[0] || !xy[1] || !std::isfinite(*xy[0]) || !std::isfinite(*xy[1]))
            f.fail(key, "entry " + std::to_string(i) + " must be an [x, y] pair of finite numbers in metres");
        pts.push_back({*xy[0], *xy[1]});
    }
    return pts;
}

std::vector<std::size_t> frame_list(const Fields &f, std::string_view key)
{
    const toml::node *n = f.node(key);
    if (!n)
        f.fail(key, "missing (required): the frame where each exciter's sweep starts");
    const toml::array *a = n->as_array();
    if (!a)
        f.fail(key, "must be an array of frame numbers");
    std::vector<std::size_t> out;
    for (std::size_t i = 0; i < a->size(); i++) {
        const auto v = (*a)[i].value_exact<int64_t>();
        if (!v || *v < 0)
            f.fail(key, "entry " + std::to_string(i) + " must be an integer >= 0");
        out.push_back(static_cast<std::size_t>(*v));
    }
    return out;
}

std::string resolve(const std::string &toml_path, const std::string &file)
{
    const std::filesystem::path p(file);
    if (p.is_absolute())
        return file;
    return (std::filesystem::path(toml_path).parent_path() / p).string();
}

WavData read_named(const Fields &f, const std::string &key, const std::string &name, const std::string &path)
{
    try {
        return read_wav(path);
    } catch (const std::runtime_error &e) {
        std::string why = e.what();
        if (why.rfind(path + ": ", 0) == 0)
            why = why.substr(path.size() + 2);
        f.fail(key, "cannot read " + name + ": " + why);
    }
}

} // namespace

Measurements load_measurements(const std::string &path, const Scene &scene, RecordingRead recording)
{
    Measurements m;
    m.file = path;
    const std::optional<std::string> bytes = io::read_file(path);
    if (!bytes)
        throw SceneError(path + ": cannot open measurements file");
    toml::table root_table;
    try {
        root_table = toml::parse(*bytes, path);
    } catch (const toml::parse_error &e) {
        std::ostringstream msg;
        msg << path << ":" << e.source().begin.line << ":" << e.source().begin.column
            << ": TOML syntax error: " << e.description();
        throw SceneError(msg.str());
    }
    const Fields root(root_table, path, "", {"scene", "excitation", "exciters", "recording", "sensor"});
    m.scene = root.string("scene").value_or("");
    if (!scene.exciters)
        throw SceneError(scene.file + ": exciters: missing section (the measurements drive the scene's exciters)");
    const std::size_t exciter_count = scene.exciters->count;

    // [excitation]
    const auto ex = root.table("excitation", {"file", "rate_hz", "sweep_hz", "sweep_s", "gap_s", "start_frames"});
    if (!ex)
        root.fail("excitation", "missing section: the plan played (file, rate_hz, sweep_s, gap_s, start_frames)");
    const auto plan_name = ex->string("file");
    if (!plan_name)
        ex->fail("file", "missing (required): the plan's WAV file");
    m.rate_hz = ex->required_positive("rate_hz");
    m.sweep_s = ex->required_positive("sweep_s");
    m.gap_s = ex->required_positive("gap_s");
    if (auto band = ex->numbers("sweep_hz", 2)) {
        if (!((*band)[0] > 0 && (*band)[0] < (*band)[1] && (*band)[1] <= m.rate_hz / 2))
            ex->fail("sweep_hz", "must be [f1, f2] with 0 < f1 < f2 <= rate_hz / 2");
        m.sweep_f1_hz = (*band)[0];
        m.sweep_f2_hz = (*band)[1];
    }
    m.start_frames = frame_list(*ex, "start_frames");

    // [exciters]
    const auto exf = root.table("exciters", {"positions_m", "force_full_scale_n"});
    if (!exf)
        root.fail("exciters", "missing section: the exciters' nominal positions (positions_m)");
    m.exciters = positions(*exf, "positions_m");
    m.force_full_scale_n = exf->positive("force_full_scale_n").value_or(scene.exciters->force_full_scale_n);

    // [recording]
    const auto rec = root.table("recording", {"file"});
    if (!rec)
        root.fail("recording", "missing section: the recording (file)");
    const auto rec_name = rec->string("file");
    if (!rec_name)
        rec->fail("file", "missing (required): the recording's WAV file");

    // [[sensor]]
    const toml::node *sn = root.node("sensor");
    if (!sn)
        root.fail("sensor", "missing: one [[sensor]] table per recorded sensor (position_m, channel, quantity)");
    const toml::array *sa = sn->as_array();
    if (!sa || sa->empty() || !sa->is_array_of_tables())
        root.fail("sensor", "must be [[sensor]] tables, at least one");
    std::vector<Fields> sensor_fields;
    for (std::size_t i = 0; i < sa->size(); i++) {
        sensor_fields.emplace_back(
            *(*sa)[i].as_table(), path, "sensor[" + std::to_string(i) + "]",
            std::initializer_list<const char *>{"position_m", "channel", "quantity", "units_per_count"});
        const Fields &f = sensor_fields.back();
        MeasuredSensor s;
        const auto pos = f.numbers("position_m", 2);
        if (!pos)
            f.fail("position_m", "missing (required): [x, y] in metres");
        s.at = {(*pos)[0], (*pos)[1]};
        if (!on_plate(scene, s.at))
            f.fail("position_m", point_words(s.at) + " is off " + plate_words(scene));
        const auto ch = f.integer("channel");
        if (!ch)
            f.fail("channel", "missing (required): the recording's channel, from 0");
        if (*ch < 0)
            f.fail("channel", "must be >= 0, got " + std::to_string(*ch));
        s.channel = static_cast<std::size_t>(*ch);
        const auto q = f.string("quantity");
        if (!q)
            f.fail("quantity", "missing (required): \"displacement\", \"velocity\" or \"acceleration\"");
        if (*q == "displacement")
            s.quantity = SensorQuantity::displacement;
        else if (*q == "velocity")
            s.quantity = SensorQuantity::velocity;
        else if (*q == "acceleration")
            s.quantity = SensorQuantity::acceleration;
        else
            f.fail("quantity", "unknown quantity \"" + *q + "\" (known: displacement, velocity, acceleration)");
        s.units_per_count = f.positive("units_per_count");
        for (std::size_t j = 0; j < m.sensors.size(); j++)
            if (m.sensors[j].channel == s.channel)
                f.fail("channel", std::to_string(s.channel) + " is sensor[" + std::to_string(j) + "]'s channel too");
        m.sensors.push_back(s);
    }

    // The plan against the scene and the keys.
    m.plan_path = resolve(path, *plan_name);
    m.plan = read_named(*ex, "file", *plan_name, m.plan_path);
    if (m.plan.rate_hz != m.rate_hz)
        ex->fail("rate_hz",
                 format_number(m.rate_hz) + " but " + *plan_name + " is at " + format_number(m.plan.rate_hz) + " Hz");
    if (m.plan.channels != exciter_count)
        ex->fail("file", *plan_name + " has " + std::to_string(m.plan.channels) + " channels but " + scene.file +
                             " has " + std::to_string(exciter_count) + " exciters");
    if (m.exciters.size() != exciter_count)
        exf->fail("positions_m",
                  std::to_string(m.exciters.size()) + " positions for " + std::to_string(exciter_count) + " exciters");
    for (std::size_t e = 0; e < m.exciters.size(); e++)
        if (!on_plate(scene, m.exciters[e]))
            exf->fail("positions_m", "entry " + std::to_string(e) + " at " + point_words(m.exciters[e]) + " is off " +
                                         plate_words(scene));
    if (m.start_frames.size() != exciter_count)
        ex->fail("start_frames",
                 std::to_string(m.start_frames.size()) + " frames for " + std::to_string(exciter_count) + " exciters");
    for (std::size_t e = 0; e < exciter_count; e++)
        if (m.start_frames[e] + m.segment_frames() > m.plan.frames)
            ex->fail("start_frames", "entry " + std::to_string(e) + ": " + std::to_string(m.start_frames[e]) + " + " +
                                         std::to_string(m.segment_frames()) +
                                         " frames (sweep_s and gap_s) run past the end of " + *plan_name + " (" +
                                         std::to_string(m.plan.frames) + " frames)");

    // The recording against the plan and the sensors.
    m.recording_path = resolve(path, *rec_name);
    if (recording == RecordingRead::skip)
        return m;
    m.recording = read_named(*rec, "file", *rec_name, m.recording_path);
    if (m.recording.rate_hz != m.plan.rate_hz)
        rec->fail("file", *rec_name + " is at " + format_number(m.recording.rate_hz) + " Hz but " + *plan_name +
                              " at " + format_number(m.plan.rate_hz) + " Hz");
    if (m.recording.frames < m.plan.frames)
        rec->fail("file", *rec_name + " has " + std::to_string(m.recording.frames) + " frames, shorter than " +
                              *plan_name + "'s " + std::to_string(m.plan.frames));
    for (std::size_t i = 0; i < m.sensors.size(); i++) {
        const Fields &f = sensor_fields[i];
        const std::size_t c = m.sensors[i].channel;
        if (c >= m.recording.channels)
            f.fail("channel", std::to_string(c) + " but " + *rec_name + " has " + std::to_string(m.recording.channels) +
                                  " channels");
        double peak = 0;
        std::size_t clipped = 0;
        for (std::size_t n = 0; n < m.recording.frames; n++) {
            const double a = std::abs(m.recording.at(n, c));
            peak = std::max(peak, a);
            clipped += a >= 0.999;
        }
        if (peak < 1.0 / 32768)
            f.fail("channel",
                   "channel " + std::to_string(c) + " of " + *rec_name + " is silence (peak below one 16-bit count)");
        if (clipped > clipped_samples_allowed)
            f.fail("channel", "channel " + std::to_string(c) + " of " + *rec_name + " is clipped (" +
                                  std::to_string(clipped) + " samples at 0.999 of full scale or beyond)");
    }
    return m;
}

} // namespace calib::scene
