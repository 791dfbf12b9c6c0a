// Field image: the field painted pixel by pixel (bilinear in the field's
// value, then the colour map, so a colour always means one value), overlays
// and axes drawn by cairo.
#include "report/field_image.h"

#include "io/format.h"
#include "report/canvas.h"
#include "report/colormap.h"
#include "report/contour.h"
#include "report/plot.h"
#include "report/ticks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace calib::report {

namespace {

using canvas::Anchor;

constexpr double tick_font = 11, label_font = 12, title_font = 14;
const Color black{0, 0, 0}, frame_grey{90, 90, 90};

void check(const FieldMap &f, const FieldStyle &s)
{
    auto fail = [&](const std::string &why) {
        throw std::invalid_argument("field image" + (s.title.empty() ? std::string() : " '" + s.title + "'") + ": " +
                                    why);
    };
    if (f.nx <= 0 || f.ny <= 0)
        fail("the lattice has no samples (nx = " + std::to_string(f.nx) + ", ny = " + std::to_string(f.ny) + ")");
    if (f.value.size() != static_cast<std::size_t>(f.nx) * static_cast<std::size_t>(f.ny))
        fail("nx * ny = " + std::to_string(static_cast<std::size_t>(f.nx) * static_cast<std::size_t>(f.ny)) +
             " but there are " + std::to_string(f.value.size()) + " values");
    if (!(f.dx_m > 0) || !(f.dy_m > 0) || !std::isfinite(f.dx_m) || !std::isfinite(f.dy_m))
        fail("the spacing must be finite and > 0");
    if (!std::isfinite(f.x0_m) || !std::isfinite(f.y0_m))
        fail("the origin is not finite");
    if (!(s.scale > 0) || !std::isfinite(s.scale))
        fail("scale must be finite and > 0");
    if ((s.vmin && !std::isfinite(*s.vmin)) || (s.vmax && !std::isfinite(*s.vmax)))
        fail("vmin and vmax must be finite");
    if (s.vmin && s.vmax && !(*s.vmax > *s.vmin))
        fail("vmax must be greater than vmin");
    if (s.threshold && !std::isfinite(*s.threshold))
        fail("the threshold is not finite");
    if (!(s.plate_x_m >= 0) || !(s.plate_y_m >= 0) || !std::isfinite(s.plate_x_m) || !std::isfinite(s.plate_y_m))
        fail("the plate size must be finite and >= 0");
    if (s.active_area) {
        const auto &a = *s.active_area;
        if (!std::all_of(a.begin(), a.end(), [](double v) { return std::isfinite(v); }) || !(a[2] > a[0]) ||
            !(a[3] > a[1]))
            fail("the active area must have x1 > x0 and y1 > y0");
    }
    for (const Marker &m : s.markers)
        if (!std::isfinite(m.x_m) || !std::isfinite(m.y_m))
            fail("marker '" + m.label + "' has a non-finite position");
    if (s.width_px < 160 || s.width_px > 8000)
        fail("width must be 160..8000 px");
}

// The field's value at a point: bilinear between the four samples around it,
// the nearest sample where one of them is NaN, NaN outside the lattice.
double sample(const FieldMap &f, double x_m, double y_m)
{
    double fi = (x_m - f.x0_m) / f.dx_m, fj = (y_m - f.y0_m) / f.dy_m;
    if (fi < -0.5 || fj < -0.5 || fi > f.nx - 0.5 || fj > f.ny - 0.5)
        return NAN;
    fi = std::clamp(fi, 0.0, f.nx - 1.0);
    fj = std::clamp(fj, 0.0, f.ny - 1.0);
    const int i = std::min(static_cast<int>(fi), std::max(0, f.nx - 2)),
              j = std::min(static_cast<int>(fj), std::max(0, f.ny - 2));
    const int i1 = std::min(i + 1, f.nx - 1), j1 = std::min(j + 1, f.ny - 1);
    const double u = fi - i, v = fj - j;
    auto at = [&](int a, int b) { return static_cast<double>(f.value[static_cast<std::size_t>(b) * f.nx + a]); };
    const double a = at(i, j), b = at(i1, j), c = at(i, j1), d = at(i1, j1);
    if (std::isfinite(a) && std::isfinite(b) && std::isfinite(c) && std::isfinite(d))
        return (1 - v) * ((1 - u) * a + u * b) + v * ((1 - u) * c + u * d);
    return at(u < 0.5 ? i : i1, v < 0.5 ? j : j1);
}

bool has_no_data(const FieldMap &f, const FieldLayout &l)
{
    if (std::any_of(f.value.begin(), f.value.end(), [](float v) { return std::isnan(v); }))
        return true;
    const double tol = 1e-9 * std::max(l.x1_m - l.x0_m, l.y1_m - l.y0_m);
    return l.x0_m < f.x0_m - 0.5 * f.dx_m - tol || l.y0_m < f.y0_m - 0.5 * f.dy_m - tol ||
           l.x1_m > f.x0_m + (f.nx - 0.5) * f.dx_m + tol || l.y1_m > f.y0_m + (f.ny - 0.5) * f.dy_m + tol;
}

// Text widths need a cairo context; the layout is computed before the surface.
double measure(const std::string &s, double size_px)
{
    std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surf(
        cairo_image_surface_create(CAIRO_FORMAT_RGB24, 1, 1), cairo_surface_destroy);
    std::unique_ptr<cairo_t, decltype(&cairo_destroy)> cr(cairo_create(surf.get()), cairo_destroy);
    cairo_select_font_face(cr.get(), "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    return canvas::text_width(cr.get(), s, size_px);
}

Ticks bar_ticks(const FieldLayout &l, const FieldStyle &s)
{
    Axis a("", AxisScale::linear);
    a.min = l.vmin * s.scale;
    a.max = l.vmax * s.scale;
    return make_ticks(a, *a.min, *a.max, "colour bar");
}

Ticks mm_ticks(double lo_m, double hi_m)
{
    Axis a("", AxisScale::linear);
    a.min = lo_m * 1e3;
    a.max = hi_m * 1e3;
    return make_ticks(a, *a.min, *a.max, "position");
}

struct LegendItem {
    enum { threshold, no_data, exciter, focus } kind;
    std::string text;
    double width;
};

std::vector<LegendItem> legend_items(const FieldMap &f, const FieldStyle &s, const FieldLayout &l)
{
    std::vector<LegendItem> items;
    if (s.threshold)
        items.push_back(
            {LegendItem::threshold, "threshold " + io::fmt("%.3g", *s.threshold * s.scale) + " " + s.unit, 0});
    if (has_no_data(f, l))
        items.push_back({LegendItem::no_data, "no data", 0});
    auto any = [&](Marker::Kind k) {
        return std::any_of(s.markers.begin(), s.markers.end(), [k](const Marker &m) { return m.kind == k; });
    };
    if (any(Marker::Kind::exciter))
        items.push_back({LegendItem::exciter, "exciter", 0});
    if (any(Marker::Kind::focus))
        items.push_back({LegendItem::focus, "focus", 0});
    for (LegendItem &it : items)
        it.width = 26 + measure(it.text, tick_font) + 16;
    return items;
}

// Rows of legend items that fit in `width`.
std::vector<std::vector<LegendItem>> legend_rows(std::vector<LegendItem> items, double width)
{
    std::vector<std::vector<LegendItem>> rows;
    double used = 0;
    for (LegendItem &it : items) {
        if (rows.empty() || used + it.width > width) {
            rows.emplace_back();
            used = 0;
        }
        used += it.width;
        rows.back().push_back(std::move(it));
    }
    return rows;
}

double value_max(const FieldMap &f)
{
    double m = -INFINITY;
    for (float v : f.value)
        if (std::isfinite(v))
            m = std::max(m, static_cast<double>(v));
    return m;
}

} // namespace

FieldLayout field_layout(const FieldMap &f, const FieldStyle &s)
{
    check(f, s);
    FieldLayout l;
    l.x0_m = s.plate_x_m > 0 ? 0 : f.x0_m - (f.nx == 1 ? 0.5 * f.dx_m : 0);
    l.x1_m = s.plate_x_m > 0 ? s.plate_x_m : f.x0_m + (f.nx == 1 ? 0.5 * f.dx_m : (f.nx - 1) * f.dx_m);
    l.y0_m = s.plate_y_m > 0 ? 0 : f.y0_m - (f.ny == 1 ? 0.5 * f.dy_m : 0);
    l.y1_m = s.plate_y_m > 0 ? s.plate_y_m : f.y0_m + (f.ny == 1 ? 0.5 * f.dy_m : (f.ny - 1) * f.dy_m);
    l.vmin = s.vmin.value_or(0.0);
    const double top = value_max(f);
    l.vmax = s.vmax.value_or(std::isfinite(top) ? top : l.vmin);
    if (!(l.vmax > l.vmin)) // a flat or empty field: one display unit of range
        l.vmax = l.vmin + 1 / s.scale;

    double bar_label_w = measure(s.unit, label_font);
    for (const std::string &t : bar_ticks(l, s).labels)
        bar_label_w = std::max(bar_label_w, measure(t, tick_font) + 7);
    const int left = 8 + 16 + 40 + 6;
    const int right = 16 + 14 + static_cast<int>(std::ceil(bar_label_w)) + 10;
    const int top_px = (s.title.empty() ? 6 : 28) + 18;
    const double aspect = (l.y1_m - l.y0_m) / (l.x1_m - l.x0_m);
    l.field_w_px = std::max(16, s.width_px - left - right);
    l.field_h_px = std::max(16, static_cast<int>(std::lround(l.field_w_px * aspect)));
    if (l.field_h_px > 2 * s.width_px) { // a tall strip: keep the image no more than twice as tall as wide
        l.field_h_px = 2 * s.width_px;
        l.field_w_px = std::max(16, static_cast<int>(std::lround(l.field_h_px / aspect)));
    }
    l.field_x_px = left;
    l.field_y_px = top_px;
    l.bar_x_px = left + l.field_w_px + 16;
    l.bar_y_px = top_px;
    l.bar_w_px = 14;
    l.bar_h_px = std::max(l.field_h_px, 100);
    const std::size_t legend = legend_rows(legend_items(f, s, l), s.width_px - left).size();
    l.width_px = s.width_px;
    l.height_px = top_px + std::max(l.field_h_px, l.bar_h_px) + 6 + 16 + 18 + static_cast<int>(legend) * 18 + 6;
    return l;
}

namespace {

void paint_field(cairo_t *cr, const FieldMap &f, const FieldLayout &l)
{
    std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> img(
        cairo_image_surface_create(CAIRO_FORMAT_RGB24, l.field_w_px, l.field_h_px), cairo_surface_destroy);
    cairo_surface_flush(img.get());
    unsigned char *base = cairo_image_surface_get_data(img.get());
    const int stride = cairo_image_surface_get_stride(img.get());
    const double sx = (l.x1_m - l.x0_m) / l.field_w_px, sy = (l.y1_m - l.y0_m) / l.field_h_px;
    for (int r = 0; r < l.field_h_px; ++r) {
        auto *row = reinterpret_cast<std::uint32_t *>(base + static_cast<std::ptrdiff_t>(r) * stride);
        const double y = l.y1_m - (r + 0.5) * sy;
        for (int k = 0; k < l.field_w_px; ++k) {
            const double v = sample(f, l.x0_m + (k + 0.5) * sx, y);
            const Color c = std::isnan(v) ? field_no_data_color : viridis((v - l.vmin) / (l.vmax - l.vmin));
            row[k] = (std::uint32_t(c.r) << 16) | (std::uint32_t(c.g) << 8) | c.b;
        }
    }
    cairo_surface_mark_dirty(img.get());
    cairo_set_source_surface(cr, img.get(), l.field_x_px, l.field_y_px); // whole pixels: an exact copy
    cairo_paint(cr);
}

void paint_bar(cairo_t *cr, const FieldLayout &l, const FieldStyle &s)
{
    for (int r = 0; r < l.bar_h_px; ++r) {
        canvas::set_color(cr, viridis(1 - (r + 0.5) / l.bar_h_px));
        cairo_rectangle(cr, l.bar_x_px, l.bar_y_px + r, l.bar_w_px, 1);
        cairo_fill(cr);
    }
    cairo_set_line_width(cr, 1);
    canvas::set_color(cr, frame_grey);
    cairo_rectangle(cr, l.bar_x_px - 0.5, l.bar_y_px - 0.5, l.bar_w_px + 1, l.bar_h_px + 1);
    cairo_stroke(cr);
    const Ticks t = bar_ticks(l, s);
    auto Y = [&](double shown) {
        return l.bar_y_px + (1 - (shown / s.scale - l.vmin) / (l.vmax - l.vmin)) * l.bar_h_px;
    };
    for (std::size_t i = 0; i < t.major.size(); ++i) {
        const double y = std::round(Y(t.major[i]) - 0.5) + 0.5, x = l.bar_x_px + l.bar_w_px;
        canvas::set_color(cr, frame_grey);
        cairo_move_to(cr, x, y);
        cairo_line_to(cr, x + 4, y);
        cairo_stroke(cr);
        canvas::set_color(cr, black);
        canvas::text(cr, x + 7, y, t.labels[i], tick_font, Anchor::start);
    }
    canvas::set_color(cr, black);
    canvas::text(cr, l.bar_x_px + l.bar_w_px / 2.0, l.bar_y_px - 10, s.unit, label_font, Anchor::middle);
    if (s.threshold && *s.threshold >= l.vmin && *s.threshold <= l.vmax) {
        const double y = Y(*s.threshold * s.scale);
        cairo_move_to(cr, l.bar_x_px - 5, y);
        cairo_line_to(cr, l.bar_x_px + l.bar_w_px + 5, y);
        cairo_set_source_rgb(cr, 0, 0, 0);
        cairo_set_line_width(cr, 4);
        cairo_stroke_preserve(cr);
        canvas::set_color(cr, field_contour_color);
        cairo_set_line_width(cr, 2);
        cairo_stroke(cr);
        cairo_set_line_width(cr, 1);
    }
}

void paint_axes(cairo_t *cr, const FieldLayout &l, const std::string &title)
{
    const double fx = l.field_x_px, fy = l.field_y_px, fw = l.field_w_px, fh = l.field_h_px;
    cairo_set_line_width(cr, 1);
    canvas::set_color(cr, frame_grey);
    cairo_rectangle(cr, fx - 0.5, fy - 0.5, fw + 1, fh + 1);
    cairo_stroke(cr);
    const Ticks tx = mm_ticks(l.x0_m, l.x1_m), ty = mm_ticks(l.y0_m, l.y1_m);
    for (std::size_t i = 0; i < tx.major.size(); ++i) {
        const double x = std::round(l.px_x(tx.major[i] * 1e-3) - 0.5) + 0.5;
        canvas::set_color(cr, frame_grey);
        cairo_move_to(cr, x, fy + fh + 0.5);
        cairo_line_to(cr, x, fy + fh + 5);
        cairo_stroke(cr);
        canvas::set_color(cr, black);
        canvas::text(cr, x, fy + fh + 6 + tick_font / 2 + 2, tx.labels[i], tick_font, Anchor::middle);
    }
    for (std::size_t i = 0; i < ty.major.size(); ++i) {
        const double y = std::round(l.px_y(ty.major[i] * 1e-3) - 0.5) + 0.5;
        canvas::set_color(cr, frame_grey);
        cairo_move_to(cr, fx - 0.5, y);
        cairo_line_to(cr, fx - 5, y);
        cairo_stroke(cr);
        canvas::set_color(cr, black);
        canvas::text(cr, fx - 7, y, ty.labels[i], tick_font, Anchor::end);
    }
    canvas::set_color(cr, black);
    canvas::text(cr, fx + fw / 2, fy + fh + 6 + 16 + label_font / 2 + 2, "x (mm)", label_font, Anchor::middle);
    canvas::text(cr, 8 + label_font / 2, fy + fh / 2, "y (mm)", label_font, Anchor::middle, true);
    if (!title.empty())
        canvas::text(cr, fx + fw / 2, 6 + title_font / 2 + 2, title, title_font, Anchor::middle);
}

// A light line on a dark halo: visible on every colour of the map.
void halo_stroke(cairo_t *cr, double width, const double *dash = nullptr)
{
    cairo_set_source_rgba(cr, 0, 0, 0, 0.55);
    cairo_set_line_width(cr, 2 * width);
    cairo_stroke_preserve(cr);
    if (dash)
        cairo_set_dash(cr, dash, 2, 0);
    canvas::set_color(cr, field_contour_color);
    cairo_set_line_width(cr, width);
    cairo_stroke(cr);
    cairo_set_dash(cr, nullptr, 0, 0);
}

// A circle with a cross: not to be mistaken for a closed threshold contour.
void focus_symbol(cairo_t *cr, double x, double y)
{
    cairo_new_sub_path(cr);
    cairo_arc(cr, x, y, 6, 0, 2 * M_PI);
    cairo_move_to(cr, x - 9, y);
    cairo_line_to(cr, x + 9, y);
    cairo_move_to(cr, x, y - 9);
    cairo_line_to(cr, x, y + 9);
    halo_stroke(cr, 1.5);
}

void exciter_symbol(cairo_t *cr, double x, double y)
{
    cairo_rectangle(cr, std::round(x) - 4.5, std::round(y) - 4.5, 9, 9);
    canvas::set_color(cr, field_exciter_color);
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0, 0, 0);
    cairo_set_line_width(cr, 1);
    cairo_stroke(cr);
}

void paint_overlays(cairo_t *cr, const FieldMap &f, const FieldLayout &l, const FieldStyle &s)
{
    cairo_save(cr);
    cairo_rectangle(cr, l.field_x_px, l.field_y_px, l.field_w_px, l.field_h_px);
    cairo_clip(cr);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    if (s.threshold) {
        for (const ContourSegment &c : contour_segments(f, *s.threshold)) {
            cairo_move_to(cr, l.px_x(c.x0_m), l.px_y(c.y0_m));
            cairo_line_to(cr, l.px_x(c.x1_m), l.px_y(c.y1_m));
        }
        halo_stroke(cr, 1.5);
    }
    if (s.active_area) { // on pixel centres: crisp 1 px dashes
        const auto &a = *s.active_area;
        auto mid = [](double v) { return std::floor(v) + 0.5; };
        const double x0 = mid(l.px_x(a[0])), x1 = mid(l.px_x(a[2])), y0 = mid(l.px_y(a[3])), y1 = mid(l.px_y(a[1]));
        cairo_rectangle(cr, x0, y0, x1 - x0, y1 - y0);
        const double dash[2] = {6, 4};
        cairo_set_line_cap(cr, CAIRO_LINE_CAP_BUTT);
        halo_stroke(cr, 1, dash);
    }
    cairo_restore(cr);
    for (const Marker &m : s.markers) {
        const double x = l.px_x(m.x_m), y = l.px_y(m.y_m);
        switch (m.kind) {
        case Marker::Kind::focus:
            focus_symbol(cr, x, y);
            break;
        case Marker::Kind::exciter:
            exciter_symbol(cr, x, y);
            break;
        case Marker::Kind::point:
            cairo_move_to(cr, x - 4, y);
            cairo_line_to(cr, x + 4, y);
            cairo_move_to(cr, x, y - 4);
            cairo_line_to(cr, x, y + 4);
            halo_stroke(cr, 1.5);
            break;
        }
        canvas::text_halo(cr, x + 8, y - 9, m.label, tick_font, Anchor::start);
    }
}

void paint_legend(cairo_t *cr, const FieldMap &f, const FieldLayout &l, const FieldStyle &s)
{
    const auto rows = legend_rows(legend_items(f, s, l), s.width_px - l.field_x_px);
    double y = l.field_y_px + std::max(l.field_h_px, l.bar_h_px) + 6 + 16 + 18 + 9;
    for (const auto &row : rows) {
        double x = l.field_x_px;
        for (const LegendItem &it : row) {
            switch (it.kind) {
            case LegendItem::threshold:
                cairo_move_to(cr, x + 2, y);
                cairo_line_to(cr, x + 20, y);
                halo_stroke(cr, 1.5);
                break;
            case LegendItem::no_data:
                canvas::set_color(cr, field_no_data_color);
                cairo_rectangle(cr, x + 5, y - 5, 10, 10);
                cairo_fill(cr);
                break;
            case LegendItem::exciter:
                exciter_symbol(cr, x + 10, y);
                break;
            case LegendItem::focus:
                cairo_set_source_rgb(cr, 0.6, 0.6, 0.6); // the symbol is light: give it a ground
                cairo_rectangle(cr, x, y - 9, 20, 18);
                cairo_fill(cr);
                focus_symbol(cr, x + 10, y);
                break;
            }
            canvas::set_color(cr, black);
            canvas::text(cr, x + 26, y, it.text, tick_font, Anchor::start);
            x += it.width;
        }
        y += 18;
    }
}

} // namespace

Image render_field(const FieldMap &field, const FieldStyle &style)
{
    const FieldLayout l = field_layout(field, style);
    return canvas::paint_image(l.width_px, l.height_px, [&](cairo_t *cr) {
        paint_field(cr, field, l);
        paint_axes(cr, l, style.title);
        paint_overlays(cr, field, l, style);
        paint_bar(cr, l, style);
        paint_legend(cr, field, l, style);
    });
}

} // namespace calib::report
