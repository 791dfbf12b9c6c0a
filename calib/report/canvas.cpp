#include "report/canvas.h"

#include "io/format.h"

#include <cairo-svg.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace calib::report::canvas {

namespace {

struct SurfaceFree {
    void operator()(cairo_surface_t *s) const { cairo_surface_destroy(s); }
};
struct ContextFree {
    void operator()(cairo_t *c) const { cairo_destroy(c); }
};
using Surface = std::unique_ptr<cairo_surface_t, SurfaceFree>;
using Context = std::unique_ptr<cairo_t, ContextFree>;

void check(cairo_status_t st, const char *what)
{
    if (st != CAIRO_STATUS_SUCCESS)
        throw std::runtime_error(std::string(what) + ": " + cairo_status_to_string(st));
}

void check_size(int w, int h)
{
    if (w <= 0 || h <= 0 || w > 32767 || h > 32767)
        throw std::invalid_argument("canvas size must be 1..32767 px per side");
}

// Text drawn on an SVG canvas, kept for <text> elements.
struct SvgText {
    double x, y; // anchor point on the baseline, device units
    std::string text;
    double size_px;
    Anchor anchor;
    bool vertical, halo;
    double r, g, b, a;
};
const cairo_user_data_key_t svg_text_key{};

std::vector<SvgText> *svg_texts(cairo_t *cr)
{
    return static_cast<std::vector<SvgText> *>(cairo_get_user_data(cr, &svg_text_key));
}

std::string num(double v)
{
    std::string s = io::fmt("%.2f", v);
    while (s.back() == '0')
        s.pop_back();
    if (s.back() == '.')
        s.pop_back();
    return s == "-0" ? "0" : s;
}

std::string svg_element(const SvgText &t)
{
    const char *anchor = t.anchor == Anchor::start ? "start" : t.anchor == Anchor::middle ? "middle" : "end";
    char fill[32];
    std::snprintf(fill, sizeof fill, "#%02x%02x%02x", static_cast<int>(std::lround(255 * t.r)),
                  static_cast<int>(std::lround(255 * t.g)), static_cast<int>(std::lround(255 * t.b)));
    std::string e = "<text x=\"" + num(t.x) + "\" y=\"" + num(t.y) + "\" font-size=\"" + num(t.size_px) +
                    "\" text-anchor=\"" + anchor + "\" fill=\"" + (t.halo ? "#ffffff" : fill) + "\"";
    if (!t.halo && t.a < 1)
        e += " fill-opacity=\"" + num(t.a) + "\"";
    if (t.halo)
        e += " stroke=\"#000000\" stroke-opacity=\"0.85\" stroke-width=\"3\" stroke-linejoin=\"round\" "
             "paint-order=\"stroke\"";
    if (t.vertical)
        e += " transform=\"rotate(-90 " + num(t.x) + " " + num(t.y) + ")\"";
    return e + ">" + xml_escape(t.text) + "</text>\n";
}

void run(cairo_surface_t *s, const DrawFn &draw, std::vector<SvgText> *texts = nullptr)
{
    check(cairo_surface_status(s), "cairo surface");
    Context cr(cairo_create(s));
    check(cairo_status(cr.get()), "cairo context");
    if (texts)
        check(cairo_set_user_data(cr.get(), &svg_text_key, texts, nullptr), "cairo user data");
    cairo_set_source_rgb(cr.get(), 1, 1, 1);
    cairo_paint(cr.get());
    cairo_select_font_face(cr.get(), "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    draw(cr.get());
    check(cairo_status(cr.get()), "cairo drawing");
}

cairo_status_t append(void *closure, const unsigned char *data, unsigned int length)
{
    static_cast<std::string *>(closure)->append(reinterpret_cast<const char *>(data), length);
    return CAIRO_STATUS_SUCCESS;
}

// FNV-1a: a stable, content-derived id prefix. Two inlined SVGs with the same
// prefix have the same content, so their shared ids resolve to equal elements.
std::string id_prefix(const std::string &s)
{
    std::uint32_t h = 2166136261u;
    for (unsigned char ch : s)
        h = (h ^ ch) * 16777619u;
    char buf[16];
    std::snprintf(buf, sizeof buf, "f%08x-", h);
    return buf;
}

void replace_all(std::string &s, const std::string &from, const std::string &to)
{
    for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
        s.replace(at, from.size(), to);
}

} // namespace

Image paint_image(int w, int h, const DrawFn &draw)
{
    check_size(w, h);
    Surface s(cairo_image_surface_create(CAIRO_FORMAT_RGB24, w, h));
    run(s.get(), draw);
    cairo_surface_flush(s.get());
    Image img{w, h, std::vector<std::uint8_t>(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3)};
    const unsigned char *base = cairo_image_surface_get_data(s.get());
    const int stride = cairo_image_surface_get_stride(s.get());
    for (int y = 0; y < h; ++y) {
        const auto *row = reinterpret_cast<const std::uint32_t *>(base + static_cast<std::ptrdiff_t>(y) * stride);
        std::uint8_t *out = &img.rgb[static_cast<std::size_t>(y) * static_cast<std::size_t>(w) * 3];
        for (int x = 0; x < w; ++x) {
            out[3 * x] = static_cast<std::uint8_t>(row[x] >> 16);
            out[3 * x + 1] = static_cast<std::uint8_t>(row[x] >> 8);
            out[3 * x + 2] = static_cast<std::uint8_t>(row[x]);
        }
    }
    return img;
}

std::string paint_svg(int w, int h, const DrawFn &draw, const std::string &title)
{
    check_size(w, h);
    std::string svg;
    std::vector<SvgText> texts;
    {
        Surface s(cairo_svg_surface_create_for_stream(append, &svg, w, h));
        check(cairo_surface_status(s.get()), "cairo SVG surface");
        cairo_svg_surface_set_document_unit(s.get(), CAIRO_SVG_UNIT_PX);
        run(s.get(), draw, &texts);
        cairo_surface_finish(s.get());
        check(cairo_surface_status(s.get()), "cairo SVG output");
    }
    const std::string prefix = id_prefix(svg);
    replace_all(svg, " id=\"", " id=\"" + prefix);
    replace_all(svg, "href=\"#", "href=\"#" + prefix);
    replace_all(svg, "url(#", "url(#" + prefix);
    const std::size_t root = svg.find("<svg");
    const std::size_t open_end = root == std::string::npos ? root : svg.find('>', root);
    const std::size_t close = svg.rfind("</svg>");
    if (open_end == std::string::npos || close == std::string::npos || close < open_end)
        throw std::runtime_error("cairo SVG output has no <svg> element");
    std::string words = "<g font-family=\"DejaVu Sans, sans-serif\">\n";
    for (const SvgText &t : texts)
        words += svg_element(t);
    svg.insert(close, words + "</g>\n");
    if (!title.empty())
        svg.insert(open_end + 1, "\n<title>" + xml_escape(title) + "</title>");
    return svg;
}

void set_color(cairo_t *cr, Color c, double alpha)
{
    cairo_set_source_rgba(cr, c.r / 255.0, c.g / 255.0, c.b / 255.0, alpha);
}

std::string valid_utf8(std::string_view s)
{
    std::string o;
    o.reserve(s.size());
    for (std::size_t i = 0; i < s.size();) {
        const auto b = static_cast<unsigned char>(s[i]);
        std::size_t n = b < 0x80 ? 1 : (b >> 5) == 0x6 ? 2 : (b >> 4) == 0xE ? 3 : (b >> 3) == 0x1E ? 4 : 0;
        bool ok = n > 0 && i + n <= s.size();
        for (std::size_t k = 1; ok && k < n; ++k)
            ok = (static_cast<unsigned char>(s[i + k]) >> 6) == 0x2;
        if (ok && n > 1) { // no overlong forms, surrogates or code points past U+10FFFF
            std::uint32_t cp = b & (0x7F >> n);
            for (std::size_t k = 1; k < n; ++k)
                cp = (cp << 6) | (static_cast<unsigned char>(s[i + k]) & 0x3F);
            static const std::uint32_t least[5] = {0, 0, 0x80, 0x800, 0x10000};
            ok = cp >= least[n] && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF);
        }
        if (!ok || (n == 1 && (b < 0x20 || b == 0x7F))) {
            o += '?';
            ++i;
            continue;
        }
        o.append(s.substr(i, n));
        i += n;
    }
    return o;
}

std::string xml_escape(std::string_view s)
{
    std::string o;
    for (char ch : valid_utf8(s)) {
        switch (ch) {
        case '&':
            o += "&amp;";
            break;
        case '<':
            o += "&lt;";
            break;
        case '>':
            o += "&gt;";
            break;
        case '"':
            o += "&quot;";
            break;
        case '\'':
            o += "&apos;";
            break;
        default:
            o += ch;
        }
    }
    return o;
}

double text_width(cairo_t *cr, std::string_view s, double size_px)
{
    const std::string t = valid_utf8(s);
    cairo_set_font_size(cr, size_px);
    cairo_text_extents_t e;
    cairo_text_extents(cr, t.c_str(), &e);
    return e.x_advance;
}

namespace {

// Moves to the baseline start of `t` anchored at (x, y), rotating the user
// space for vertical text (the caller brackets this with save and restore).
void place(cairo_t *cr, double x, double y, const std::string &t, double size_px, Anchor a, bool vertical)
{
    cairo_set_font_size(cr, size_px);
    cairo_text_extents_t e;
    cairo_text_extents(cr, t.c_str(), &e);
    cairo_font_extents_t fe;
    cairo_font_extents(cr, &fe);
    cairo_translate(cr, x, y);
    if (vertical)
        cairo_rotate(cr, -M_PI / 2);
    const double u = a == Anchor::start ? 0 : a == Anchor::middle ? -0.5 * e.x_advance : -e.x_advance;
    // Centre the capital height on y: ascent minus descent is about twice the
    // distance from the baseline to the middle of a capital in DejaVu Sans.
    cairo_move_to(cr, u, 0.5 * (fe.ascent - fe.descent));
}

// On an SVG canvas: records the text for a <text> element instead of glyphs.
bool to_svg(cairo_t *cr, double x, double y, const std::string &t, double size_px, Anchor a, bool vertical, bool halo)
{
    std::vector<SvgText> *texts = svg_texts(cr);
    if (!texts)
        return false;
    cairo_save(cr);
    cairo_set_font_size(cr, size_px);
    cairo_font_extents_t fe;
    cairo_font_extents(cr, &fe);
    const double lift = 0.5 * (fe.ascent - fe.descent);
    double bx = vertical ? x + lift : x, by = vertical ? y : y + lift;
    cairo_user_to_device(cr, &bx, &by);
    double r = 0, g = 0, b = 0, alpha = 1;
    cairo_pattern_get_rgba(cairo_get_source(cr), &r, &g, &b, &alpha); // leaves black for a non-solid source
    cairo_restore(cr);
    texts->push_back({bx, by, t, size_px, a, vertical, halo, r, g, b, alpha});
    return true;
}

} // namespace

void text(cairo_t *cr, double x, double y, std::string_view s, double size_px, Anchor a, bool vertical)
{
    const std::string t = valid_utf8(s);
    if (t.empty() || to_svg(cr, x, y, t, size_px, a, vertical, false))
        return;
    cairo_save(cr);
    place(cr, x, y, t, size_px, a, vertical);
    cairo_show_text(cr, t.c_str());
    cairo_restore(cr);
}

void text_halo(cairo_t *cr, double x, double y, std::string_view s, double size_px, Anchor a)
{
    const std::string t = valid_utf8(s);
    if (t.empty() || to_svg(cr, x, y, t, size_px, a, false, true))
        return;
    cairo_save(cr);
    place(cr, x, y, t, size_px, a, false);
    cairo_text_path(cr, t.c_str());
    cairo_set_source_rgba(cr, 0, 0, 0, 0.85);
    cairo_set_line_width(cr, 3);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    cairo_stroke_preserve(cr);
    cairo_set_source_rgb(cr, 1, 1, 1);
    cairo_fill(cr);
    cairo_restore(cr);
}

} // namespace calib::report::canvas
