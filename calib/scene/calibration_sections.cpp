#include "scene/calibration_sections.h"

#include <cmath>
#include <set>

namespace calib::scene {

namespace {

// An array of [x, y] pairs in metres.
std::vector<pipeline::Point> point_list(const Fields &f, std::string_view key)
{
    const toml::node *n = f.node(key);
    const toml::array *a = n ? n->as_array() : nullptr;
    if (!a)
        f.fail(key, "must be an array of [x, y] pairs in metres");
    std::vector<pipeline::Point> pts;
    for (size_t i = 0; i < a->size(); i++) {
        const toml::array *p = (*a)[i].as_array();
        if (!p || p->size() != 2)
            f.fail(key, "entry " + std::to_string(i) + " must be an [x, y] pair in metres");
        double xy[2];
        for (size_t k = 0; k < 2; k++) {
            auto v = (*p)[k].value<double>();
            if (!v || !std::isfinite(*v))
                f.fail(key, "entry " + std::to_string(i) + " must hold two finite numbers");
            xy[k] = *v;
        }
        pts.push_back({xy[0], xy[1]});
    }
    return pts;
}

template <class E>
E one_of(const Fields &f, std::string_view key, E fallback, std::initializer_list<std::pair<const char *, E>> words)
{
    auto w = f.string(key);
    if (!w)
        return fallback;
    std::string list;
    for (const auto &[name, value] : words) {
        if (*w == name)
            return value;
        list += (list.empty() ? "" : ", ") + std::string(name);
    }
    f.fail(key, "unknown value \"" + *w + "\" (known: " + list + ")");
}

double fraction(const Fields &f, std::string_view key, double fallback, bool allow_one)
{
    auto v = f.number(key);
    if (!v)
        return fallback;
    if (!(*v > 0 && (allow_one ? *v <= 1 : *v < 1)))
        f.fail(key, std::string("must lie in (0, 1") + (allow_one ? "]" : ")") + ", got " + format_number(*v));
    return *v;
}

double non_negative(const Fields &f, std::string_view key, double fallback)
{
    auto v = f.number(key);
    if (!v)
        return fallback;
    if (!(*v >= 0 && std::isfinite(*v)))
        f.fail(key, "must be >= 0, got " + format_number(*v));
    return *v;
}

unsigned count_in(const Fields &f, std::string_view key, unsigned fallback, long long lo, long long hi)
{
    auto v = f.integer(key);
    if (!v)
        return fallback;
    if (*v < lo || *v > hi)
        f.fail(key, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " + std::to_string(*v));
    return static_cast<unsigned>(*v);
}

} // namespace

pipeline::ActiveAreaSpec parse_active_area(const Fields &f)
{
    pipeline::ActiveAreaSpec a;
    auto r = f.numbers("rect_m", 4);
    if (!r)
        f.fail("rect_m", "missing (required): [x0, y0, x1, y1] in metres, plate origin at the lower-left corner");
    if (!((*r)[0] < (*r)[2] && (*r)[1] < (*r)[3]))
        f.fail("rect_m", "needs x0 < x1 and y0 < y1");
    a.area = {(*r)[0], (*r)[1], (*r)[2], (*r)[3]};
    a.frame_margin_m = non_negative(f, "frame_margin_m", 0.0);
    a.clearance_m = non_negative(f, "clearance_m", 0.0);
    return a;
}

pipeline::ExcitersSpec parse_exciters(const Fields &f)
{
    using pipeline::PlacementMode, pipeline::PlacementCriterion;
    pipeline::ExcitersSpec e;
    e.count = count_in(f, "count", 8, 1, 32);
    e.placement = one_of<PlacementMode>(
        f, "placement", PlacementMode::random,
        {{"random", PlacementMode::random}, {"regular", PlacementMode::regular}, {"fixed", PlacementMode::fixed}});
    e.criterion = one_of<PlacementCriterion>(
        f, "criterion", PlacementCriterion::contrast,
        {{"contrast", PlacementCriterion::contrast}, {"distance_variety", PlacementCriterion::distance_variety}});
    if (auto s = f.integer("seed")) {
        if (*s < 0)
            f.fail("seed", "must be >= 0, got " + std::to_string(*s));
        e.seed = static_cast<uint64_t>(*s);
    }
    e.min_spacing_m = non_negative(f, "min_spacing_m", e.min_spacing_m);
    if (auto v = f.positive("force_full_scale_n"))
        e.force_full_scale_n = *v;
    if (auto v = f.positive("site_spacing_m"))
        e.site_spacing_m = *v;
    if (auto w = f.string("contrast_window")) {
        if (*w != "all" && *w != "focus")
            f.fail("contrast_window", "unknown value \"" + *w + "\" (known: all, focus)");
        e.contrast_at_focus_instant = *w == "focus";
    }
    e.restarts = count_in(f, "restarts", e.restarts, 1, 1000);
    e.iterations = count_in(f, "iterations", e.iterations, 0, 1000000);
    e.verdict_rounds = count_in(f, "verdict_rounds", e.verdict_rounds, 0, 50);
    if (f.has("placement_foci"))
        e.placement_foci = count_in(f, "placement_foci", 0, 2, 1024);
    if (f.has("positions_m")) {
        if (e.placement != PlacementMode::fixed)
            f.fail("positions_m", "only with placement = \"fixed\"");
        e.positions = point_list(f, "positions_m");
        if (!f.has("count"))
            e.count = static_cast<unsigned>(e.positions.size());
        if (e.positions.size() != e.count)
            f.fail("positions_m",
                   std::to_string(e.positions.size()) + " positions for count = " + std::to_string(e.count));
        if (e.count < 1 || e.count > 32)
            f.fail("positions_m", "1 to 32 positions");
    } else if (e.placement == PlacementMode::fixed) {
        f.fail("positions_m", "missing (required with placement = \"fixed\"): [[x, y], ...] in metres");
    }
    if (f.has("force_gains")) {
        if (e.placement != PlacementMode::fixed)
            f.fail("force_gains", "only with placement = \"fixed\" (a gain belongs to a glued exciter)");
        auto g = f.numbers("force_gains", e.count);
        if (!g)
            f.fail("force_gains", "must be " + std::to_string(e.count) + " numbers, one per exciter");
        for (double v : *g)
            if (!(v > 0 && std::isfinite(v)))
                f.fail("force_gains", "must be positive and finite");
        e.force_gains = *g;
    }
    return e;
}

pipeline::FociSpec parse_foci(const Fields &f, const pipeline::ActiveAreaSpec &active)
{
    pipeline::FociSpec s;
    const bool grid = f.has("grid"), pitch = f.has("pitch_m"), points = f.has("points_m");
    if (int(grid) + int(pitch) + int(points) != 1)
        f.fail(points  ? "points_m"
               : pitch ? "pitch_m"
                       : "grid",
               "give exactly one of grid = [nx, ny], pitch_m = p or points_m = [[x, y], ...]");
    const pipeline::Rect &a = active.area;
    if (grid) {
        auto g = f.numbers("grid", 2);
        if (!g)
            f.fail("grid", "must be [nx, ny] (foci per row and column)");
        const double nx = (*g)[0], ny = (*g)[1];
        if (nx != std::floor(nx) || ny != std::floor(ny) || nx < 1 || ny < 1 || nx * ny > 1024)
            f.fail("grid", "needs whole numbers >= 1 and at most 1024 foci");
        // Cell centres of an nx x ny division of the active area, row by row
        // from the lower-left corner (x fastest), ids from 1.
        uint32_t id = 1;
        for (int j = 0; j < static_cast<int>(ny); j++)
            for (int i = 0; i < static_cast<int>(nx); i++)
                s.points.push_back(
                    {id++, {a.x0_m + (a.x1_m - a.x0_m) * (i + 0.5) / nx, a.y0_m + (a.y1_m - a.y0_m) * (j + 0.5) / ny}});
    } else if (pitch) {
        // A square grid of this pitch filling the active area: as many points
        // per axis as fit (the span a multiple of the pitch), centred, row by
        // row from the lower-left corner (x fastest), ids from 1. Whether the
        // plate grid resolves the pitch is checked once the grid is known
        // (pipeline::check_feasible).
        const double p = *f.positive("pitch_m");
        const double w = a.x1_m - a.x0_m, h = a.y1_m - a.y0_m;
        const double nx = std::floor(w / p * (1 + 1e-9)) + 1, ny = std::floor(h / p * (1 + 1e-9)) + 1;
        if (!(nx * ny <= 1024))
            f.fail("pitch_m", format_number(p) + " m fills the " + format_number(w) + " x " + format_number(h) +
                                  " m active area with " + format_number(nx * ny) + " foci, more than 1024");
        const double ox = a.x0_m + (w - (nx - 1) * p) / 2, oy = a.y0_m + (h - (ny - 1) * p) / 2;
        uint32_t id = 1;
        for (int j = 0; j < static_cast<int>(ny); j++)
            for (int i = 0; i < static_cast<int>(nx); i++)
                s.points.push_back({id++, {ox + i * p, oy + j * p}});
        s.pitch_m = p;
    } else {
        std::vector<pipeline::Point> pts = point_list(f, "points_m");
        if (pts.empty() || pts.size() > 1024)
            f.fail("points_m", "needs 1 to 1024 points");
        std::vector<uint32_t> ids;
        if (const toml::node *n = f.node("ids")) {
            const toml::array *arr = n->as_array();
            if (!arr || arr->size() != pts.size())
                f.fail("ids", "must be an array of " + std::to_string(pts.size()) + " integers (one per point)");
            std::set<int64_t> seen;
            for (const toml::node &e : *arr) {
                auto v = e.value<int64_t>();
                if (!v || *v < 0 || *v > 0xFFFFFFFFll || !seen.insert(*v).second)
                    f.fail("ids", "must be distinct integers in [0, 4294967295]");
                ids.push_back(static_cast<uint32_t>(*v));
            }
        }
        for (size_t i = 0; i < pts.size(); i++)
            s.points.push_back({ids.empty() ? static_cast<uint32_t>(i + 1) : ids[i], pts[i]});
    }
    if (f.has("ids") && !points)
        f.fail("ids", "only with points_m (grid and pitch_m foci are numbered 1.. row by row)");
    return s;
}

pipeline::PulseSpec parse_pulse(const Fields &f)
{
    pipeline::PulseSpec p;
    if (auto s = f.string("shape")) {
        try {
            p.shape = pipeline::parse_pulse_shape(*s);
        } catch (const std::invalid_argument &e) {
            f.fail("shape", e.what());
        }
    }
    p.centre_hz = f.required_positive("centre_hz");
    if (auto c = f.positive("cycles")) {
        if (*c < 0.5 || *c > 100)
            f.fail("cycles", "must lie in [0.5, 100], got " + format_number(*c));
        p.cycles = *c;
    }
    if (auto a = f.positive("amplitude_m"))
        p.amplitude_m = *a;
    return p;
}

pipeline::CalibrationSpec parse_calibration(const Fields &f)
{
    pipeline::CalibrationSpec c;
    if (auto v = f.positive("window_s"))
        c.window_s = *v;
    c.truncate_fraction = fraction(f, "truncate_fraction", c.truncate_fraction, true);
    if (auto v = f.positive("output_rate_hz")) {
        if (*v != std::floor(*v) || *v < 8000 || *v > 384000)
            f.fail("output_rate_hz", "must be a whole number of Hz in [8000, 384000], got " + format_number(*v));
        c.output_rate_hz = *v;
    }
    if (auto s = f.string("sample_format")) {
        if (*s != "s16")
            f.fail("sample_format", "unknown format \"" + *s + "\" (known: s16)");
        c.sample_format = *s;
    }
    if (auto v = f.positive("threshold_m"))
        c.threshold_m = *v;
    if (auto b = f.boolean("dither"))
        c.dither = *b;
    if (auto v = f.positive("accuracy")) {
        if (*v >= 1)
            f.fail("accuracy", "is a relative error, must lie in (0, 1), got " + format_number(*v));
        c.accuracy = *v;
    }
    c.verify_tail_s = non_negative(f, "verify_tail_s", c.verify_tail_s);
    c.method = one_of<pipeline::DriveMethod>(f, "method", c.method,
                                             {{"time_reversal", pipeline::DriveMethod::time_reversal},
                                              {"inverse_filter", pipeline::DriveMethod::inverse_filter}});
    c.exciter_gains = one_of<pipeline::ExciterGainsMode>(
        f, "exciter_gains", c.exciter_gains,
        {{"minimax", pipeline::ExciterGainsMode::minimax}, {"equal", pipeline::ExciterGainsMode::equal}});
    if (f.has("exciter_gains") && c.method != pipeline::DriveMethod::time_reversal)
        f.fail("exciter_gains", "needs method = \"time_reversal\" (the inverse filter designs every exciter's "
                                "drive, its level included)");
    if (auto v = f.positive("lead_time_s"))
        c.lead_time_s = *v;
    c.regularization = non_negative(f, "regularization", c.regularization);
    c.active_damping_s = non_negative(f, "active_damping_s", c.active_damping_s);
    if (c.active_damping_s > 0 && c.method != pipeline::DriveMethod::inverse_filter)
        f.fail("active_damping_s", "needs method = \"inverse_filter\" (time reversal's drive is the reversed "
                                   "response: nothing of it follows the focal instant)");
    if (c.active_damping_s > c.window_s)
        f.fail("active_damping_s", "must not exceed window_s (" + format_number(c.window_s) + " s), got " +
                                       format_number(c.active_damping_s));
    return c;
}

} // namespace calib::scene
