// One layout pass (ranges, ticks, legend) drawn on an abstract canvas; two
// canvases: SVG text and an anti-aliased RGB raster written as PNG.
#include "report/plot.h"

#include "io/atomic_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#define STB_IMAGE_WRITE_STATIC  // private copy: no clash with other users of stb
#define STB_IMAGE_WRITE_IMPLEMENTATION
#include <stb/stb_easy_font.h>
#include <stb/stb_image_write.h>
#pragma GCC diagnostic pop

namespace calib::report {

Color palette(std::size_t i)
{
    // Tableau 10, then darker companions, so 20 series stay distinct.
    static const Color colors[] = {{31, 119, 180}, {255, 127, 14}, {44, 160, 44},  {214, 39, 40},
                                   {148, 103, 189}, {140, 86, 75}, {227, 119, 194}, {127, 127, 127},
                                   {188, 189, 34},  {23, 190, 207}, {10, 60, 110},  {160, 80, 0},
                                   {20, 90, 20},    {120, 10, 10},  {80, 50, 120},  {80, 40, 30},
                                   {150, 40, 110},  {40, 40, 40},   {110, 110, 0},  {0, 110, 120}};
    return colors[i % (sizeof colors / sizeof colors[0])];
}

namespace {

struct Pt {
    double x, y;
};
struct Rect {
    double x, y, w, h;
};
enum class Anchor { start, middle, end };

const Color black{0, 0, 0}, grid_grey{225, 225, 225}, frame_grey{90, 90, 90}, white{255, 255, 255};

class Canvas {
public:
    virtual ~Canvas() = default;
    virtual void set_clip(const Rect *r) = 0;
    virtual void polyline(const std::vector<Pt> &pts, Color c, double width, LineStyle style) = 0;
    virtual void dot(Pt p, double radius, Color c) = 0;
    virtual void fill_rect(Rect r, Color c) = 0;
    // y is the middle of the text line; vertical text reads bottom to top.
    virtual void text(Pt p, const std::string &s, double size_px, Anchor a, bool vertical, Color c) = 0;
    virtual double text_width(const std::string &s, double size_px) = 0;
};

// Dash pattern in px (on, off) for a style; empty: solid.
std::vector<double> dash_pattern(LineStyle s, double width)
{
    if (s == LineStyle::dashed)
        return {4 * width + 2, 2.5 * width + 1};
    if (s == LineStyle::dotted)
        return {width, 1.5 * width + 1};
    return {};
}

// ---------------------------------------------------------------- SVG

std::string xml_escape(const std::string &s)
{
    std::string o;
    for (char ch : s) {
        switch (ch) {
        case '&': o += "&amp;"; break;
        case '<': o += "&lt;"; break;
        case '>': o += "&gt;"; break;
        case '"': o += "&quot;"; break;
        default:
            if (static_cast<unsigned char>(ch) >= 0x20 || ch == '\t' || ch == '\n')
                o += ch;
        }
    }
    return o;
}

std::string hex(Color c)
{
    char buf[8];
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", c.r, c.g, c.b);
    return buf;
}

std::string num(double v)
{
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    return buf;
}

class SvgCanvas final : public Canvas {
public:
    SvgCanvas(int w, int h)
    {
        out_ << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
             << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << w << "\" height=\"" << h
             << "\" viewBox=\"0 0 " << w << ' ' << h << "\" font-family=\"DejaVu Sans, Arial, sans-serif\">\n"
             << "<rect x=\"0\" y=\"0\" width=\"" << w << "\" height=\"" << h << "\" fill=\"#ffffff\"/>\n";
    }
    std::string finish()
    {
        out_ << "</svg>\n";
        return out_.str();
    }
    void set_clip(const Rect *r) override
    {
        if (!r) {
            clip_attr_.clear();
            return;
        }
        const std::string id = "clip" + std::to_string(++clips_);
        out_ << "<defs><clipPath id=\"" << id << "\"><rect x=\"" << num(r->x) << "\" y=\"" << num(r->y)
             << "\" width=\"" << num(r->w) << "\" height=\"" << num(r->h) << "\"/></clipPath></defs>\n";
        clip_attr_ = " clip-path=\"url(#" + id + ")\"";
    }
    void polyline(const std::vector<Pt> &pts, Color c, double width, LineStyle style) override
    {
        out_ << "<polyline fill=\"none\" stroke=\"" << hex(c) << "\" stroke-width=\"" << num(width)
             << "\" stroke-linejoin=\"round\" stroke-linecap=\"butt\"";
        const std::vector<double> dash = dash_pattern(style, width);
        if (!dash.empty())
            out_ << " stroke-dasharray=\"" << num(dash[0]) << ' ' << num(dash[1]) << '"';
        out_ << clip_attr_ << " points=\"";
        for (std::size_t i = 0; i < pts.size(); ++i)
            out_ << (i ? " " : "") << num(pts[i].x) << ',' << num(pts[i].y);
        out_ << "\"/>\n";
    }
    void dot(Pt p, double radius, Color c) override
    {
        out_ << "<circle cx=\"" << num(p.x) << "\" cy=\"" << num(p.y) << "\" r=\"" << num(radius) << "\" fill=\""
             << hex(c) << '"' << clip_attr_ << "/>\n";
    }
    void fill_rect(Rect r, Color c) override
    {
        out_ << "<rect x=\"" << num(r.x) << "\" y=\"" << num(r.y) << "\" width=\"" << num(r.w) << "\" height=\""
             << num(r.h) << "\" fill=\"" << hex(c) << "\"/>\n";
    }
    void text(Pt p, const std::string &s, double size_px, Anchor a, bool vertical, Color c) override
    {
        const char *anchor = a == Anchor::start ? "start" : a == Anchor::middle ? "middle" : "end";
        out_ << "<text x=\"" << num(p.x) << "\" y=\"" << num(p.y) << "\" dy=\"0.35em\" font-size=\"" << num(size_px)
             << "\" text-anchor=\"" << anchor << "\" fill=\"" << hex(c) << '"';
        if (vertical)
            out_ << " transform=\"rotate(-90 " << num(p.x) << ' ' << num(p.y) << ")\"";
        out_ << '>' << xml_escape(s) << "</text>\n";
    }
    double text_width(const std::string &s, double size_px) override
    {
        return 0.62 * size_px * static_cast<double>(s.size());  // DejaVu Sans average advance
    }

private:
    std::ostringstream out_;
    std::string clip_attr_;
    int clips_ = 0;
};

// ---------------------------------------------------------------- raster

// Coverage mask over a box of the image: each shape takes the max coverage
// per pixel, then the mask is blended once, so overlapping segments of one
// polyline do not darken their joints.
class Mask {
public:
    Mask(int x0, int y0, int x1, int y1) : x0_(x0), y0_(y0), w_(std::max(0, x1 - x0)), h_(std::max(0, y1 - y0)),
                                           a_(static_cast<std::size_t>(w_) * static_cast<std::size_t>(h_), 0.0f) {}
    void put(int x, int y, double cov)
    {
        if (x < x0_ || y < y0_ || x >= x0_ + w_ || y >= y0_ + h_ || cov <= 0)
            return;
        float &v = a_[static_cast<std::size_t>(y - y0_) * static_cast<std::size_t>(w_) + static_cast<std::size_t>(x - x0_)];
        v = std::max(v, static_cast<float>(std::min(cov, 1.0)));
    }
    int x0_, y0_, w_, h_;
    std::vector<float> a_;
};

// stb_easy_font indexes a table by (char - 32): keep to printable ASCII.
std::string printable(const std::string &s)
{
    std::string o = s;
    for (char &ch : o)
        if (ch < 32 || ch > 126)
            ch = '?';
    return o;
}

class RasterCanvas final : public Canvas {
public:
    RasterCanvas(int w, int h) : img_{w, h, std::vector<std::uint8_t>(static_cast<std::size_t>(w) * h * 3, 255)} {}
    Image take() { return std::move(img_); }

    void set_clip(const Rect *r) override
    {
        if (r)
            clip_ = {static_cast<int>(std::floor(r->x)), static_cast<int>(std::floor(r->y)),
                     static_cast<int>(std::ceil(r->x + r->w)), static_cast<int>(std::ceil(r->y + r->h))};
        else
            clip_ = {0, 0, img_.width, img_.height};
    }
    void polyline(const std::vector<Pt> &pts, Color c, double width, LineStyle style) override
    {
        if (pts.size() < 2)
            return;
        const double half = 0.5 * width;
        double bx0 = pts[0].x, bx1 = pts[0].x, by0 = pts[0].y, by1 = pts[0].y;
        for (const Pt &p : pts) {
            bx0 = std::min(bx0, p.x); bx1 = std::max(bx1, p.x);
            by0 = std::min(by0, p.y); by1 = std::max(by1, p.y);
        }
        Mask m = make_mask(bx0 - half - 1, by0 - half - 1, bx1 + half + 2, by1 + half + 2);
        const std::vector<double> dash = dash_pattern(style, width);
        const double period = dash.empty() ? 0 : dash[0] + dash[1];
        double s0 = 0;  // arc length at the segment start, for the dash phase
        for (std::size_t i = 0; i + 1 < pts.size(); ++i) {
            const Pt a = pts[i], b = pts[i + 1];
            const double dx = b.x - a.x, dy = b.y - a.y, len2 = dx * dx + dy * dy, len = std::sqrt(len2);
            const int x0 = std::max(m.x0_, static_cast<int>(std::floor(std::min(a.x, b.x) - half - 1)));
            const int x1 = std::min(m.x0_ + m.w_, static_cast<int>(std::ceil(std::max(a.x, b.x) + half + 1)));
            const int y0 = std::max(m.y0_, static_cast<int>(std::floor(std::min(a.y, b.y) - half - 1)));
            const int y1 = std::min(m.y0_ + m.h_, static_cast<int>(std::ceil(std::max(a.y, b.y) + half + 1)));
            for (int y = y0; y < y1; ++y)
                for (int x = x0; x < x1; ++x) {
                    const double px = x + 0.5 - a.x, py = y + 0.5 - a.y;
                    double t = len2 > 0 ? (px * dx + py * dy) / len2 : 0;
                    t = std::clamp(t, 0.0, 1.0);
                    const double ex = px - t * dx, ey = py - t * dy;
                    const double dist = std::sqrt(ex * ex + ey * ey);
                    double cov = half + 0.5 - dist;
                    if (cov <= 0)
                        continue;
                    if (period > 0 && std::fmod(s0 + t * len, period) > dash[0])
                        continue;
                    m.put(x, y, cov);
                }
            s0 += len;
        }
        blend(m, c);
    }
    void dot(Pt p, double radius, Color c) override
    {
        Mask m = make_mask(p.x - radius - 1, p.y - radius - 1, p.x + radius + 2, p.y + radius + 2);
        for (int y = m.y0_; y < m.y0_ + m.h_; ++y)
            for (int x = m.x0_; x < m.x0_ + m.w_; ++x)
                m.put(x, y, radius + 0.5 - std::hypot(x + 0.5 - p.x, y + 0.5 - p.y));
        blend(m, c);
    }
    void fill_rect(Rect r, Color c) override
    {
        Mask m = make_mask(r.x - 1, r.y - 1, r.x + r.w + 1, r.y + r.h + 1);
        cover_rect(m, r.x, r.y, r.x + r.w, r.y + r.h);
        blend(m, c);
    }
    void text(Pt p, const std::string &s, double size_px, Anchor a, bool vertical, Color c) override
    {
        if (s.empty())
            return;
        std::string buf = printable(s);  // stb_easy_font takes char *, ASCII only
        const double scale = size_px / font_units;
        const double w = stb_easy_font_width(buf.data()) * scale;
        // Text-local frame: u along the text, v down; origin at the line's
        // anchor point and vertical middle (glyph rows 0..7 of the font).
        const double u0 = a == Anchor::start ? 0 : a == Anchor::middle ? -0.5 * w : -w;
        const double v0 = -3.5 * scale;
        std::vector<char> quads(buf.size() * 64 * 40);
        const int n = stb_easy_font_print(0, 0, buf.data(), nullptr, quads.data(), static_cast<int>(quads.size()));
        const double reach = w + size_px;
        Mask m = make_mask(p.x - reach, p.y - reach, p.x + reach, p.y + reach);
        for (int q = 0; q < n; ++q) {
            double qu0 = 1e300, qu1 = -1e300, qv0 = 1e300, qv1 = -1e300;
            for (int k = 0; k < 4; ++k) {
                float xy[2];
                std::memcpy(xy, quads.data() + (q * 4 + k) * 16, sizeof xy);
                qu0 = std::min(qu0, double(xy[0])); qu1 = std::max(qu1, double(xy[0]));
                qv0 = std::min(qv0, double(xy[1])); qv1 = std::max(qv1, double(xy[1]));
            }
            const double u_lo = u0 + qu0 * scale, u_hi = u0 + qu1 * scale;
            const double v_lo = v0 + qv0 * scale, v_hi = v0 + qv1 * scale;
            if (!vertical)
                cover_rect(m, p.x + u_lo, p.y + v_lo, p.x + u_hi, p.y + v_hi);
            else  // rotate -90 degrees: u -> up, v -> right
                cover_rect(m, p.x + v_lo, p.y - u_hi, p.x + v_hi, p.y - u_lo);
        }
        blend(m, c);
    }
    double text_width(const std::string &s, double size_px) override
    {
        std::string buf = printable(s);
        return stb_easy_font_width(buf.data()) * size_px / font_units;
    }

private:
    // stb_easy_font capitals are 7 units tall; scale so they are ~0.7 em.
    static constexpr double font_units = 10.0;

    Mask make_mask(double x0, double y0, double x1, double y1) const
    {
        return Mask(std::max(clip_.x0, static_cast<int>(std::floor(x0))), std::max(clip_.y0, static_cast<int>(std::floor(y0))),
                    std::min(clip_.x1, static_cast<int>(std::ceil(x1))), std::min(clip_.y1, static_cast<int>(std::ceil(y1))));
    }
    static void cover_rect(Mask &m, double x0, double y0, double x1, double y1)
    {
        for (int y = static_cast<int>(std::floor(y0)); y < static_cast<int>(std::ceil(y1)); ++y) {
            const double cy = std::min<double>(y + 1, y1) - std::max<double>(y, y0);
            for (int x = static_cast<int>(std::floor(x0)); x < static_cast<int>(std::ceil(x1)); ++x) {
                const double cx = std::min<double>(x + 1, x1) - std::max<double>(x, x0);
                m.put(x, y, cx * cy);
            }
        }
    }
    void blend(const Mask &m, Color c)
    {
        for (int y = 0; y < m.h_; ++y)
            for (int x = 0; x < m.w_; ++x) {
                const float a = m.a_[static_cast<std::size_t>(y) * m.w_ + x];
                if (a <= 0)
                    continue;
                std::uint8_t *px = &img_.rgb[(static_cast<std::size_t>(m.y0_ + y) * img_.width + (m.x0_ + x)) * 3];
                const std::uint8_t src[3] = {c.r, c.g, c.b};
                for (int k = 0; k < 3; ++k)
                    px[k] = static_cast<std::uint8_t>(std::lround(px[k] + (src[k] - px[k]) * a));
            }
    }

    struct IRect {
        int x0, y0, x1, y1;
    };
    Image img_;
    IRect clip_{0, 0, img_.width, img_.height};
};

// ---------------------------------------------------------------- layout

struct Ticks {
    double lo, hi;                   // axis range (data units)
    std::vector<double> major, minor;
    std::vector<std::string> labels;  // one per major tick
};

std::string tick_label(double v, double step)
{
    char buf[32];
    if (v == 0)
        return "0";
    const double a = std::abs(v);
    if (a >= 1e6 || a < 1e-3) {
        std::snprintf(buf, sizeof buf, "%.3g", v);
        std::string o = buf;  // 2.5e+06 -> 2.5e6
        for (const char *from : {"e+0", "e+", "e-0"}) {
            const std::size_t at = o.find(from);
            if (at != std::string::npos) {
                o.replace(at, std::strlen(from), from[1] == '-' ? "e-" : "e");
                break;
            }
        }
        return o;
    } else {
        const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
        std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    }
    return buf;
}

std::string decade_label(int e)
{
    if (e >= -3 && e <= 4) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%g", std::pow(10.0, e));
        return buf;
    }
    return "1e" + std::to_string(e);
}

bool usable(double v, AxisScale s)
{
    return std::isfinite(v) && (s == AxisScale::linear || v > 0);
}

Ticks make_ticks(const Axis &axis, double dmin, double dmax, const char *which)
{
    Ticks t{};
    if (axis.scale == AxisScale::log) {
        if ((axis.min && !(*axis.min > 0)) || (axis.max && !(*axis.max > 0)))
            throw std::invalid_argument(std::string(which) + " axis: log scale needs positive min and max");
        double lo = axis.min.value_or(dmin), hi = axis.max.value_or(dmax);
        if (!(hi > lo)) {
            lo /= 10;
            hi *= 10;
        }
        int e0 = static_cast<int>(std::floor(std::log10(lo) + 1e-9)), e1 = static_cast<int>(std::ceil(std::log10(hi) - 1e-9));
        if (e1 <= e0)
            e1 = e0 + 1;
        t.lo = axis.min ? lo : std::pow(10.0, e0);
        t.hi = axis.max ? hi : std::pow(10.0, e1);
        const int every = std::max(1, (e1 - e0 + 7) / 8);
        for (int e = e0; e <= e1; ++e) {
            const double d = std::pow(10.0, e);
            if (d >= t.lo * (1 - 1e-9) && d <= t.hi * (1 + 1e-9) && (e - e0) % every == 0) {
                t.major.push_back(d);
                t.labels.push_back(decade_label(e));
            }
            if (every == 1)
                for (int k = 2; k <= 9; ++k)
                    if (k * d > t.lo && k * d < t.hi)
                        t.minor.push_back(k * d);
        }
        return t;
    }
    double lo = axis.min.value_or(dmin), hi = axis.max.value_or(dmax);
    if (!(hi > lo)) {
        const double pad = lo == 0 ? 1 : 0.1 * std::abs(lo);
        lo -= pad;
        hi += pad;
    }
    const double raw = (hi - lo) / 6;
    const double p10 = std::pow(10.0, std::floor(std::log10(raw)));
    double step = p10;
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (m * p10 >= raw) {
            step = m * p10;
            break;
        }
    t.lo = axis.min ? lo : std::floor(lo / step + 1e-9) * step;
    t.hi = axis.max ? hi : std::ceil(hi / step - 1e-9) * step;
    for (double v = std::ceil(t.lo / step - 1e-9) * step; v <= t.hi + 1e-9 * step; v += step) {
        const double snapped = std::abs(v) < 1e-12 * step ? 0.0 : v;
        t.major.push_back(snapped);
        t.labels.push_back(tick_label(snapped, step));
    }
    return t;
}

void check(const Plot &p)
{
    if (p.width_px < 64 || p.height_px < 64 || p.width_px > 20000 || p.height_px > 20000)
        throw std::invalid_argument("plot size must be 64..20000 px per side");
    for (const Series &s : p.series)
        if (s.x.size() != s.y.size())
            throw std::invalid_argument("series '" + s.label + "': x and y lengths differ");
}

void draw(const Plot &p, Canvas &cv)
{
    check(p);
    double xmin = std::numeric_limits<double>::infinity(), xmax = -xmin, ymin = xmin, ymax = -xmin;
    for (const Series &s : p.series)
        for (std::size_t i = 0; i < s.x.size(); ++i)
            if (usable(s.x[i], p.x.scale) && usable(s.y[i], p.y.scale)) {
                xmin = std::min(xmin, s.x[i]); xmax = std::max(xmax, s.x[i]);
                ymin = std::min(ymin, s.y[i]); ymax = std::max(ymax, s.y[i]);
            }
    if (!std::isfinite(xmin) && !(p.x.min && p.x.max && p.y.min && p.y.max))
        throw std::invalid_argument("plot '" + p.title + "' has no drawable data point");
    if (!std::isfinite(xmin)) {
        xmin = *p.x.min; xmax = *p.x.max; ymin = *p.y.min; ymax = *p.y.max;
    }
    const Ticks tx = make_ticks(p.x, xmin, xmax, "x"), ty = make_ticks(p.y, ymin, ymax, "y");

    const double tick_font = 13, label_font = 15, title_font = 17;
    double ylab_w = 0;
    for (const std::string &l : ty.labels)
        ylab_w = std::max(ylab_w, cv.text_width(l, tick_font));
    const double left = 20 + (p.y.label.empty() ? 0 : label_font + 8) + ylab_w + 8;
    const double top = p.title.empty() ? 16 : title_font + 24;
    const double bottom = 12 + tick_font + 10 + (p.x.label.empty() ? 0 : label_font + 10);
    const double right = 24;
    const Rect area{left, top, p.width_px - left - right, p.height_px - top - bottom};
    if (area.w < 16 || area.h < 16)
        throw std::invalid_argument("plot too small for its labels");

    auto tf = [](double v, AxisScale s) { return s == AxisScale::log ? std::log10(v) : v; };
    const double tx0 = tf(tx.lo, p.x.scale), tx1 = tf(tx.hi, p.x.scale);
    const double ty0 = tf(ty.lo, p.y.scale), ty1 = tf(ty.hi, p.y.scale);
    auto X = [&](double v) { return area.x + (tf(v, p.x.scale) - tx0) / (tx1 - tx0) * area.w; };
    auto Y = [&](double v) { return area.y + area.h - (tf(v, p.y.scale) - ty0) / (ty1 - ty0) * area.h; };

    // Grid, frame, ticks, labels.
    for (double v : tx.major)
        cv.polyline({{X(v), area.y}, {X(v), area.y + area.h}}, grid_grey, 1, LineStyle::solid);
    for (double v : ty.major)
        cv.polyline({{area.x, Y(v)}, {area.x + area.w, Y(v)}}, grid_grey, 1, LineStyle::solid);
    for (double v : tx.minor)
        cv.polyline({{X(v), area.y + area.h}, {X(v), area.y + area.h - 4}}, frame_grey, 1, LineStyle::solid);
    for (double v : ty.minor)
        cv.polyline({{area.x, Y(v)}, {area.x + 4, Y(v)}}, frame_grey, 1, LineStyle::solid);
    for (std::size_t i = 0; i < tx.major.size(); ++i) {
        const double x = X(tx.major[i]);
        cv.polyline({{x, area.y + area.h}, {x, area.y + area.h + 5}}, frame_grey, 1, LineStyle::solid);
        cv.text({x, area.y + area.h + 8 + tick_font / 2}, tx.labels[i], tick_font, Anchor::middle, false, black);
    }
    for (std::size_t i = 0; i < ty.major.size(); ++i) {
        const double y = Y(ty.major[i]);
        cv.polyline({{area.x - 5, y}, {area.x, y}}, frame_grey, 1, LineStyle::solid);
        cv.text({area.x - 8, y}, ty.labels[i], tick_font, Anchor::end, false, black);
    }
    cv.polyline({{area.x, area.y}, {area.x + area.w, area.y}, {area.x + area.w, area.y + area.h},
                 {area.x, area.y + area.h}, {area.x, area.y}},
                frame_grey, 1, LineStyle::solid);
    if (!p.title.empty())
        cv.text({area.x + area.w / 2, 8 + title_font / 2 + 2}, p.title, title_font, Anchor::middle, false, black);
    if (!p.x.label.empty())
        cv.text({area.x + area.w / 2, p.height_px - 8 - label_font / 2}, p.x.label, label_font, Anchor::middle, false, black);
    if (!p.y.label.empty())
        cv.text({12 + label_font / 2, area.y + area.h / 2}, p.y.label, label_font, Anchor::middle, true, black);

    // Data, clipped to the plot area.
    cv.set_clip(&area);
    for (std::size_t si = 0; si < p.series.size(); ++si) {
        const Series &s = p.series[si];
        const Color c = s.color.value_or(palette(si));
        std::vector<Pt> run;
        auto flush = [&] {
            if (s.style != LineStyle::none && run.size() >= 2)
                cv.polyline(run, c, s.width_px, s.style);
            run.clear();
        };
        for (std::size_t i = 0; i < s.x.size(); ++i) {
            if (!usable(s.x[i], p.x.scale) || !usable(s.y[i], p.y.scale)) {
                flush();
                continue;
            }
            const Pt pt{X(s.x[i]), Y(s.y[i])};
            // Keep far-off points finite for the rasterizer's bounding boxes.
            run.push_back({std::clamp(pt.x, -4.0 * p.width_px, 5.0 * p.width_px),
                           std::clamp(pt.y, -4.0 * p.height_px, 5.0 * p.height_px)});
            if (s.markers)
                cv.dot(pt, s.width_px + 1.5, c);
        }
        flush();
    }
    cv.set_clip(nullptr);

    // Legend.
    std::vector<std::size_t> entries;
    for (std::size_t i = 0; i < p.series.size(); ++i)
        if (!p.series[i].label.empty())
            entries.push_back(i);
    if (p.legend == LegendPosition::hidden || entries.empty())
        return;
    const double row = tick_font + 7, sample = 32;
    double text_w = 0;
    for (std::size_t i : entries)
        text_w = std::max(text_w, cv.text_width(p.series[i].label, tick_font));
    const double bw = 10 + sample + 8 + text_w + 10, bh = 8 + row * static_cast<double>(entries.size()) + 2;
    const bool at_right = p.legend == LegendPosition::top_right || p.legend == LegendPosition::bottom_right;
    const bool at_top = p.legend == LegendPosition::top_right || p.legend == LegendPosition::top_left;
    const double bx = at_right ? area.x + area.w - bw - 10 : area.x + 10;
    const double by = at_top ? area.y + 10 : area.y + area.h - bh - 10;
    cv.fill_rect({bx, by, bw, bh}, frame_grey);
    cv.fill_rect({bx + 1, by + 1, bw - 2, bh - 2}, white);
    for (std::size_t k = 0; k < entries.size(); ++k) {
        const Series &s = p.series[entries[k]];
        const Color c = s.color.value_or(palette(entries[k]));
        const double y = by + 6 + row * (static_cast<double>(k) + 0.5);
        if (s.style != LineStyle::none)
            cv.polyline({{bx + 10, y}, {bx + 10 + sample, y}}, c, s.width_px, s.style);
        if (s.markers)
            cv.dot({bx + 10 + sample / 2, y}, s.width_px + 1.5, c);
        cv.text({bx + 10 + sample + 8, y}, s.label, tick_font, Anchor::start, false, black);
    }
}

}  // namespace

std::string render_svg(const Plot &plot)
{
    check(plot);
    SvgCanvas cv(plot.width_px, plot.height_px);
    draw(plot, cv);
    return cv.finish();
}

Image render_image(const Plot &plot)
{
    check(plot);
    RasterCanvas cv(plot.width_px, plot.height_px);
    draw(plot, cv);
    return cv.take();
}

std::vector<std::uint8_t> encode_png(const Image &img)
{
    std::vector<std::uint8_t> out;
    auto append = [](void *ctx, void *data, int size) {
        auto *v = static_cast<std::vector<std::uint8_t> *>(ctx);
        v->insert(v->end(), static_cast<std::uint8_t *>(data), static_cast<std::uint8_t *>(data) + size);
    };
    if (!stbi_write_png_to_func(append, &out, img.width, img.height, 3, img.rgb.data(), img.width * 3))
        throw std::runtime_error("PNG encoding failed");
    return out;
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

}  // namespace calib::report
