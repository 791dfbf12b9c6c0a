// One layout pass (ranges, ticks, legend) drawn through cairo on either an
// image surface (PNG) or an SVG surface.
#include "report/plot.h"

#include "io/atomic_file.h"
#include "report/canvas.h"
#include "report/ticks.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <limits>
#include <stdexcept>

namespace calib::report {

Color palette(std::size_t i)
{
    // Tableau 10, then darker companions, so 20 series stay distinct.
    static const Color colors[] = {{31, 119, 180}, {255, 127, 14},  {44, 160, 44},   {214, 39, 40},  {148, 103, 189},
                                   {140, 86, 75},  {227, 119, 194}, {127, 127, 127}, {188, 189, 34}, {23, 190, 207},
                                   {10, 60, 110},  {160, 80, 0},    {20, 90, 20},    {120, 10, 10},  {80, 50, 120},
                                   {80, 40, 30},   {150, 40, 110},  {40, 40, 40},    {110, 110, 0},  {0, 110, 120}};
    return colors[i % (sizeof colors / sizeof colors[0])];
}

namespace {

using canvas::Anchor;

struct Rect {
    double x, y, w, h;
};

const Color black{0, 0, 0}, grid_grey{225, 225, 225}, frame_grey{90, 90, 90}, white{255, 255, 255};
constexpr double tick_font = 13, label_font = 15, title_font = 17;

void line(cairo_t *cr, double x0, double y0, double x1, double y1, Color c, double width = 1)
{
    canvas::set_color(cr, c);
    cairo_set_line_width(cr, width);
    cairo_move_to(cr, x0, y0);
    cairo_line_to(cr, x1, y1);
    cairo_stroke(cr);
}

void set_style(cairo_t *cr, LineStyle s, double width)
{
    cairo_set_line_width(cr, width);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    cairo_set_line_cap(cr, s == LineStyle::dotted ? CAIRO_LINE_CAP_ROUND : CAIRO_LINE_CAP_BUTT);
    if (s == LineStyle::dashed) {
        const double d[2] = {4 * width + 2, 2.5 * width + 1};
        cairo_set_dash(cr, d, 2, 0);
    } else if (s == LineStyle::dotted) {
        const double d[2] = {0, 2 * width + 1}; // round caps on zero-length dashes: dots
        cairo_set_dash(cr, d, 2, 0);
    } else {
        cairo_set_dash(cr, nullptr, 0, 0);
    }
}

void dot(cairo_t *cr, double x, double y, double r, Color c)
{
    canvas::set_color(cr, c);
    cairo_new_sub_path(cr);
    cairo_arc(cr, x, y, r, 0, 2 * M_PI);
    cairo_fill(cr);
}

bool usable(double v, AxisScale s) { return std::isfinite(v) && (s == AxisScale::linear || v > 0); }

void check(const Plot &p)
{
    if (p.width_px < 64 || p.height_px < 64 || p.width_px > 20000 || p.height_px > 20000)
        throw std::invalid_argument("plot size must be 64..20000 px per side");
    for (const Series &s : p.series)
        if (s.x.size() != s.y.size())
            throw std::invalid_argument("series '" + s.label + "': x and y lengths differ");
}

struct Layout {
    Ticks tx, ty;
};

Layout ticks_of(const Plot &p)
{
    check(p);
    double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
    for (const Series &s : p.series)
        for (std::size_t i = 0; i < s.x.size(); ++i)
            if (usable(s.x[i], p.x.scale) && usable(s.y[i], p.y.scale)) {
                xmin = std::min(xmin, s.x[i]);
                xmax = std::max(xmax, s.x[i]);
                ymin = std::min(ymin, s.y[i]);
                ymax = std::max(ymax, s.y[i]);
            }
    if (!std::isfinite(xmin) && !(p.x.min && p.x.max && p.y.min && p.y.max))
        throw std::invalid_argument("plot '" + p.title + "' has no drawable data point");
    if (!std::isfinite(xmin)) {
        xmin = *p.x.min;
        xmax = *p.x.max;
        ymin = *p.y.min;
        ymax = *p.y.max;
    }
    return {make_ticks(p.x, xmin, xmax, "x"), make_ticks(p.y, ymin, ymax, "y")};
}

void draw_legend(cairo_t *cr, const Plot &p, const Rect &area)
{
    std::vector<std::size_t> entries;
    for (std::size_t i = 0; i < p.series.size(); ++i)
        if (!p.series[i].label.empty())
            entries.push_back(i);
    if (p.legend == LegendPosition::hidden || entries.empty())
        return;
    const double row = tick_font + 7, sample = 32;
    double text_w = 0;
    for (std::size_t i : entries)
        text_w = std::max(text_w, canvas::text_width(cr, p.series[i].label, tick_font));
    const double bw = 10 + sample + 8 + text_w + 10, bh = 8 + row * static_cast<double>(entries.size()) + 2;
    const bool at_right = p.legend == LegendPosition::top_right || p.legend == LegendPosition::bottom_right;
    const bool at_top = p.legend == LegendPosition::top_right || p.legend == LegendPosition::top_left;
    const double bx = at_right ? area.x + area.w - bw - 10 : area.x + 10;
    const double by = at_top ? area.y + 10 : area.y + area.h - bh - 10;
    cairo_rectangle(cr, bx + 0.5, by + 0.5, bw - 1, bh - 1);
    canvas::set_color(cr, white, 0.92);
    cairo_fill_preserve(cr);
    canvas::set_color(cr, frame_grey);
    cairo_set_line_width(cr, 1);
    cairo_stroke(cr);
    for (std::size_t k = 0; k < entries.size(); ++k) {
        const Series &s = p.series[entries[k]];
        const Color c = s.color.value_or(palette(entries[k]));
        const double y = by + 6 + row * (static_cast<double>(k) + 0.5);
        if (s.style != LineStyle::none) {
            set_style(cr, s.style, s.width_px);
            canvas::set_color(cr, c);
            cairo_move_to(cr, bx + 10, y);
            cairo_line_to(cr, bx + 10 + sample, y);
            cairo_stroke(cr);
            set_style(cr, LineStyle::solid, 1);
        }
        if (s.markers)
            dot(cr, bx + 10 + sample / 2, y, s.width_px + 1.5, c);
        canvas::set_color(cr, black);
        canvas::text(cr, bx + 10 + sample + 8, y, s.label, tick_font, Anchor::start);
    }
}

void draw(const Plot &p, const Layout &lay, cairo_t *cr)
{
    const Ticks &tx = lay.tx, &ty = lay.ty;
    double ylab_w = 0;
    for (const std::string &l : ty.labels)
        ylab_w = std::max(ylab_w, canvas::text_width(cr, l, tick_font));
    const double left = 20 + (p.y.label.empty() ? 0 : label_font + 8) + ylab_w + 8;
    const double top = p.title.empty() ? 16 : title_font + 24;
    const double bottom = 12 + tick_font + 10 + (p.x.label.empty() ? 0 : label_font + 10);
    const double right = 24;
    // Whole pixels for the frame, so its 1 px lines are crisp.
    const Rect area{std::round(left) + 0.5, std::round(top) + 0.5, std::round(p.width_px - left - right),
                    std::round(p.height_px - top - bottom)};
    if (area.w < 16 || area.h < 16)
        throw std::invalid_argument("plot too small for its labels");

    auto tf = [](double v, AxisScale s) { return s == AxisScale::log ? std::log10(v) : v; };
    const double tx0 = tf(tx.lo, p.x.scale), tx1 = tf(tx.hi, p.x.scale);
    const double ty0 = tf(ty.lo, p.y.scale), ty1 = tf(ty.hi, p.y.scale);
    auto X = [&](double v) { return area.x + (tf(v, p.x.scale) - tx0) / (tx1 - tx0) * area.w; };
    auto Y = [&](double v) { return area.y + area.h - (tf(v, p.y.scale) - ty0) / (ty1 - ty0) * area.h; };
    auto crisp = [](double v) { return std::round(v - 0.5) + 0.5; }; // a 1 px line on one pixel column

    for (double v : tx.major)
        line(cr, crisp(X(v)), area.y, crisp(X(v)), area.y + area.h, grid_grey);
    for (double v : ty.major)
        line(cr, area.x, crisp(Y(v)), area.x + area.w, crisp(Y(v)), grid_grey);
    for (double v : tx.minor)
        line(cr, crisp(X(v)), area.y + area.h, crisp(X(v)), area.y + area.h - 4, frame_grey);
    for (double v : ty.minor)
        line(cr, area.x, crisp(Y(v)), area.x + 4, crisp(Y(v)), frame_grey);
    canvas::set_color(cr, black);
    for (std::size_t i = 0; i < tx.major.size(); ++i) {
        const double x = crisp(X(tx.major[i]));
        line(cr, x, area.y + area.h, x, area.y + area.h + 5, frame_grey);
        canvas::set_color(cr, black);
        canvas::text(cr, x, area.y + area.h + 8 + tick_font / 2, tx.labels[i], tick_font, Anchor::middle);
    }
    for (std::size_t i = 0; i < ty.major.size(); ++i) {
        const double y = crisp(Y(ty.major[i]));
        line(cr, area.x - 5, y, area.x, y, frame_grey);
        canvas::set_color(cr, black);
        canvas::text(cr, area.x - 8, y, ty.labels[i], tick_font, Anchor::end);
    }
    cairo_rectangle(cr, area.x, area.y, area.w, area.h);
    canvas::set_color(cr, frame_grey);
    cairo_set_line_width(cr, 1);
    cairo_stroke(cr);
    canvas::set_color(cr, black);
    if (!p.title.empty())
        canvas::text(cr, area.x + area.w / 2, 8 + title_font / 2 + 2, p.title, title_font, Anchor::middle);
    if (!p.x.label.empty())
        canvas::text(cr, area.x + area.w / 2, p.height_px - 8 - label_font / 2, p.x.label, label_font, Anchor::middle);
    if (!p.y.label.empty())
        canvas::text(cr, 12 + label_font / 2, area.y + area.h / 2, p.y.label, label_font, Anchor::middle, true);

    // Data, clipped to the plot area.
    cairo_save(cr);
    cairo_rectangle(cr, area.x, area.y, area.w, area.h);
    cairo_clip(cr);
    for (std::size_t si = 0; si < p.series.size(); ++si) {
        const Series &s = p.series[si];
        const Color c = s.color.value_or(palette(si));
        set_style(cr, s.style, s.width_px);
        canvas::set_color(cr, c);
        bool open = false; // a NaN (or <= 0 on a log axis) ends the current run
        double last_x = 0, last_y = 0;
        for (std::size_t i = 0; i < s.x.size(); ++i) {
            if (!usable(s.x[i], p.x.scale) || !usable(s.y[i], p.y.scale)) {
                open = false;
                continue;
            }
            // Far-off points clamped within cairo's fixed-point range; 1/8 px
            // steps (invisible) keep SVG path numbers to three decimals.
            const double x = std::round(8 * std::clamp(X(s.x[i]), -4.0 * p.width_px, 5.0 * p.width_px)) / 8;
            const double y = std::round(8 * std::clamp(Y(s.y[i]), -4.0 * p.height_px, 5.0 * p.height_px)) / 8;
            if (open && x == last_x && y == last_y)
                continue;
            if (open)
                cairo_line_to(cr, x, y);
            else
                cairo_move_to(cr, x, y);
            open = true;
            last_x = x;
            last_y = y;
        }
        if (s.style != LineStyle::none)
            cairo_stroke(cr);
        cairo_new_path(cr);
        if (s.markers)
            for (std::size_t i = 0; i < s.x.size(); ++i)
                if (usable(s.x[i], p.x.scale) && usable(s.y[i], p.y.scale))
                    dot(cr, X(s.x[i]), Y(s.y[i]), s.width_px + 1.5, c);
    }
    set_style(cr, LineStyle::solid, 1);
    cairo_restore(cr);
    draw_legend(cr, p, area);
}

} // namespace

std::string render_svg(const Plot &plot)
{
    const Layout lay = ticks_of(plot);
    return canvas::paint_svg(
        plot.width_px, plot.height_px, [&](cairo_t *cr) { draw(plot, lay, cr); }, plot.title);
}

Image render_image(const Plot &plot)
{
    const Layout lay = ticks_of(plot);
    return canvas::paint_image(plot.width_px, plot.height_px, [&](cairo_t *cr) { draw(plot, lay, cr); });
}

void write_svg(const Plot &plot, const std::string &path) { io::write_file_atomic(path, render_svg(plot)); }

void write_png(const Plot &plot, const std::string &path)
{
    const std::vector<std::uint8_t> png = encode_png(render_image(plot));
    io::write_file_atomic(path, std::string_view(reinterpret_cast<const char *>(png.data()), png.size()));
}

void write_plot(const Plot &plot, const std::string &path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
    if (ext == ".svg")
        write_svg(plot, path);
    else if (ext == ".png")
        write_png(plot, path);
    else
        throw std::invalid_argument(path + ": plot file must end in .svg or .png");
}

} // namespace calib::report
