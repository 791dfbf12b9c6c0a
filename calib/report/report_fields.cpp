#include "report/report_fields.h"

#include "io/format.h"
#include "report/contrast_map.h"
#include "report/field_image.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

namespace calib::report {

using pipeline::FocusMetrics;
using pipeline::Point;

std::string num(double v, int prec) { return io::fmt("%.*g", prec, v); }

bool few_foci(const ReportContext &c) { return c.verification->foci.size() <= max_foci_drawn; }

std::vector<size_t> shown_foci(const ReportContext &c)
{
    const std::vector<FocusMetrics> &m = c.verification->foci;
    std::vector<size_t> order(m.size());
    for (size_t f = 0; f < m.size(); f++)
        order[f] = f;
    if (few_foci(c) || c.mode != "table")
        return order;
    auto key = [&](size_t f) { return m[f].whole_area ? m[f].whole_area_contrast_db : m[f].other_foci_contrast_db; };
    std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return key(a) < key(b); });
    return {order.front(), order[order.size() / 2], order.back()};
}

namespace {

// |w| at each focus's instant on the node lattice, on one colour scale in um
// for all foci (one colour, one displacement), the threshold as a contour.
// The plate, the active area, the foci and the exciters, the threshold as a
// contour; the colour scale from 0 to vmax_m.
FieldStyle field_style(const ReportContext &c, double vmax_m, int width_px, std::optional<size_t> driven)
{
    const auto &pp = c.input->plate->params();
    FieldStyle s;
    s.vmax = vmax_m > 0 ? vmax_m : 1e-6;
    s.threshold = c.input->calibration.threshold_m;
    s.plate_x_m = pp.size_x_m;
    s.plate_y_m = pp.size_y_m;
    const pipeline::Rect &a = c.input->active.area;
    s.active_area = std::array<double, 4>{a.x0_m, a.y0_m, a.x1_m, a.y1_m};
    // Every focus of a few; of a dense grid the driven one only (markers would hide the field).
    for (size_t f = 0; f < c.input->foci.points.size(); f++)
        if (few_foci(c) || driven == f) {
            const pipeline::FocusPoint &p = c.input->foci.points[f];
            s.markers.push_back({p.at.x_m, p.at.y_m, std::to_string(p.id), Marker::Kind::focus});
        }
    for (size_t e = 0; e < c.exciters.size(); e++)
        s.markers.push_back({c.exciters[e].x_m, c.exciters[e].y_m, std::to_string(e), Marker::Kind::exciter});
    s.width_px = width_px;
    return s;
}

FieldMap lattice_map(const pipeline::Verification &v, std::vector<float> values)
{
    return {v.grid_nx + 1, v.grid_ny + 1, 0, 0, v.grid_h_m, v.grid_h_m, std::move(values)};
}

// The worst focus (least whole-area contrast): the largest |w| each point of
// the plate reaches at any time of the playback and its decay (a ghost is a
// bright patch away from the focus), and |w| over time as a movie, both on
// the scale of its focal peak with the threshold as a contour.
std::string worst_focus_html(const ReportContext &c)
{
    const pipeline::Verification &v = *c.verification;
    const size_t f = v.worst_focus;
    if (v.max_abs.size() <= f || v.max_abs[f].empty() || v.frames.empty())
        return "";
    const pipeline::FocusMetrics &m = v.foci[f];
    std::ostringstream h;
    h << "<h2>Whole area: the worst focus</h2><p>Focus " << m.id << " has the least whole-area contrast ("
      << num(m.whole_area_contrast_db) << " dB): its focal peak over the largest |w| anywhere in the active area "
      << "farther than lambda/2 from it, at any time.</p><div class='grid'>";
    FieldStyle s = field_style(c, m.peak_m, 440, f);
    s.title = "max |w| over all times, focus " + std::to_string(m.id);
    const std::vector<std::string> img = render_field_uris({lattice_map(v, v.max_abs[f])}, {s});
    h << "<figure class='cell'><img src='" << img[0] << "' alt='max |w| over all times'><figcaption>max |w| at "
      << "every point over the playback and its decay; white line: the threshold</figcaption></figure></div>";
    // At most 60 frames over the whole run: enough to follow a wave front
    // across the plate, small enough for a self-contained page.
    const size_t step = std::max<size_t>(1, (v.frames.size() + 59) / 60);
    std::vector<FieldMap> frames;
    std::vector<double> times;
    for (size_t k = 0; k < v.frames.size(); k += step) {
        std::vector<float> a(v.frames[k].size());
        for (size_t n = 0; n < a.size(); n++)
            a[n] = std::abs(v.frames[k][n]);
        frames.push_back(lattice_map(v, std::move(a)));
        times.push_back(static_cast<double>(k) / v.frame_rate_hz);
    }
    s.title = "|w| over time, focus " + std::to_string(m.id);
    s.width_px = 400;
    h << "<figure>" << field_movie_html(frames, times, s, "worst-focus-movie")
      << "<figcaption>|w| from the start of playback, every " << num(1e3 * step / v.frame_rate_hz)
      << " ms; same colour scale as above</figcaption></figure>";
    return h.str();
}

// The shown foci's snapshots (shown_foci order).
std::vector<std::string> snapshot_imgs(const ReportContext &c, const std::vector<size_t> &shown)
{
    const pipeline::Verification &v = *c.verification;
    float vmax_m = 0;
    for (const std::vector<float> &snap : v.snapshots)
        for (float w : snap)
            vmax_m = std::max(vmax_m, w);
    std::vector<FieldMap> maps;
    std::vector<FieldStyle> styles;
    for (size_t f : shown) {
        maps.push_back(lattice_map(v, v.snapshots[f]));
        styles.push_back(field_style(c, vmax_m, 440, f));
    }
    std::vector<std::string> imgs = render_field_uris(maps, styles);
    for (size_t k = 0; k < imgs.size(); k++)
        imgs[k] = "<img src='" + imgs[k] + "' alt='|w| when focus " + std::to_string(v.foci[shown[k]].id) + " peaks'>";
    return imgs;
}

// Whole-area contrast of every focus over the active area: each focus's cell
// coloured by its figure (dB), the margin a focus at the target amplitude
// needs drawn as the threshold, the foci where the area beyond lambda/2
// crosses the threshold marked, the worst focus labelled.
std::string contrast_map_html(const ReportContext &c)
{
    const pipeline::Verification &v = *c.verification;
    if (v.foci.empty() || v.max_abs.empty())
        return "";
    std::vector<Point> at;
    std::vector<double> db;
    for (const FocusMetrics &m : v.foci) {
        if (!m.whole_area)
            return "";
        at.push_back(m.at);
        db.push_back(m.whole_area_contrast_db);
    }
    const auto [lo, hi] = std::minmax_element(db.begin(), db.end());
    FieldStyle s = field_style(c, 0, 520, v.worst_focus);
    s.title = "whole-area contrast per focus, all times";
    s.unit = "dB";
    s.scale = 1;
    s.vmin = std::floor(*lo);
    s.vmax = std::max(std::ceil(*hi), *s.vmin + 1);
    const double need = 20 * std::log10(c.input->pulse.amplitude_m / c.input->calibration.threshold_m);
    s.threshold = need;
    size_t crossing = 0;
    for (const FocusMetrics &m : v.foci)
        if (!m.passes()) {
            crossing++;
            s.markers.push_back({m.at.x_m, m.at.y_m, "", Marker::Kind::point});
        }
    const std::vector<std::string> img = render_field_uris({nearest_focus_map(at, db, c.input->active.area)}, {s});
    std::ostringstream h;
    h << "<h2>Whole-area contrast over the active area</h2><figure><img src='" << img[0]
      << "' alt='whole-area contrast per focus'><figcaption>Each focus's cell (the points nearer to it than to any "
      << "other focus) in the colour of its whole-area contrast: its focal peak over the largest |w| in the active "
      << "area farther than lambda/2 from it, at all times. White line: " << num(need) << " dB = 20 log10("
      << num(c.input->pulse.amplitude_m * 1e6) << " um target / " << num(c.input->calibration.threshold_m * 1e6)
      << " um threshold), the margin a focus at its target peak needs for nothing beyond lambda/2 to reach the "
      << "threshold. Crosses: the " << crossing << " of " << v.foci.size()
      << " foci where something beyond lambda/2 does reach it. Labelled: the worst focus. Range " << num(*lo) << " to "
      << num(*hi) << " dB.</figcaption></figure>";
    return h.str();
}

} // namespace

std::string field_sections_html(const ReportContext &c, const std::vector<size_t> &shown)
{
    const pipeline::Verification &v = *c.verification;
    std::ostringstream h;
    h << contrast_map_html(c) << "<h2>Wave field at the focus instant</h2>";
    if (!few_foci(c))
        h << "<p>" << v.foci.size() << " foci: the worst, the median and the best by whole-area contrast.</p>";
    h << "<div class='grid'>";
    const std::vector<std::string> snapshots = snapshot_imgs(c, shown);
    for (size_t k = 0; k < shown.size(); k++)
        h << "<figure class='cell'>" << snapshots[k] << "<figcaption>|w| when focus " << v.foci[shown[k]].id
          << " peaks (" << num(v.foci[shown[k]].lead_time_s * 1e3)
          << " ms); one colour scale for all foci, white line: the threshold</figcaption></figure>";
    h << "</div>" << worst_focus_html(c);
    return h.str();
}

} // namespace calib::report
