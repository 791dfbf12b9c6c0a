// Field images and movies: a linear ramp is painted with the published
// viridis colours at the positions where it takes their values, the threshold
// contour lies where the field crosses the threshold (a straight line for a
// ramp, a circle of the analytic radius for a Gaussian), NaN samples and the
// plate outside the lattice are "no data", markers sit at their positions,
// bad input is refused, and a movie is one self-contained well-formed
// fragment with one frame per input on one shared colour scale.
#include "report/contour.h"
#include "report/field_image.h"

#include "xml_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "png_decode.h"

using namespace calib::report;
using xml_check::count;

namespace {

// viridis at 0, 1/4, 1/2, 3/4 and 1 as matplotlib publishes it
// (matplotlib.colors.to_hex(viridis(t))).
const Color published[5] = {
    {0x44, 0x01, 0x54}, {0x3b, 0x52, 0x8b}, {0x21, 0x91, 0x8c}, {0x5e, 0xc9, 0x62}, {0xfd, 0xe7, 0x25}};

// w = 1e-5 m per metre of x over a 1 m x 0.5 m lattice.
FieldMap ramp()
{
    FieldMap f{201, 11, 0, 0, 0.005, 0.05, {}};
    for (int j = 0; j < f.ny; ++j)
        for (int i = 0; i < f.nx; ++i)
            f.value.push_back(static_cast<float>(1e-5 * i * f.dx_m));
    return f;
}

FieldStyle ramp_style()
{
    FieldStyle s;
    s.vmin = 0.0;
    s.vmax = 1e-5;
    s.width_px = 640;
    return s;
}

bool whitish(Color c) { return c.r >= 235 && c.g >= 235 && c.b >= 235; }

// Pixel (column, row) of a plate position.
int col(const FieldLayout &l, double x_m) { return static_cast<int>(std::floor(l.px_x(x_m))); }
int row(const FieldLayout &l, double y_m) { return static_cast<int>(std::floor(l.px_y(y_m))); }

} // namespace

TEST(FieldImage, RampIsPaintedWithThePublishedViridisColours)
{
    const FieldMap f = ramp();
    const FieldStyle s = ramp_style();
    const FieldLayout l = field_layout(f, s);
    const Image img = render_field(f, s);
    ASSERT_EQ(img.width, l.width_px);
    ASSERT_EQ(img.height, l.height_px);
    EXPECT_NEAR(static_cast<double>(l.field_h_px) / l.field_w_px, 0.5, 0.01); // the plate's aspect
    // Column k shows x = (k + 0.5) / width m: the first column after each
    // quarter shows the quarter's colour (entry floor(256 t)).
    for (int q = 0; q <= 4; ++q) {
        const int k = q == 4 ? l.field_w_px - 1 : q * l.field_w_px / 4 + (q * l.field_w_px % 4 ? 1 : 0);
        for (int r = l.field_y_px; r < l.field_y_px + l.field_h_px; r += 7)
            ASSERT_EQ(img.at(l.field_x_px + k, r), published[q]) << "quarter " << q << ", row " << r;
    }
}

TEST(FieldImage, ThresholdContourIsWhereARampCrossesIt)
{
    const FieldMap f = ramp();
    FieldStyle s = ramp_style();
    s.threshold = 0.3e-5; // crossed at x = 0.3 m
    const FieldLayout l = field_layout(f, s);
    const Image img = render_field(f, s);
    const double want = l.px_x(0.3);
    for (int r = l.field_y_px + 2; r < l.field_y_px + l.field_h_px - 2; ++r) {
        int hits = 0;
        for (int k = l.field_x_px; k < l.field_x_px + l.field_w_px; ++k)
            if (whitish(img.at(k, r))) {
                EXPECT_NEAR(k + 0.5, want, 1.5) << "row " << r;
                ++hits;
            }
        EXPECT_GE(hits, 1) << "row " << r;
    }
    // The marching squares segments themselves: every end point at x = 0.3.
    const std::vector<ContourSegment> segs = contour_segments(f, 0.3e-5);
    EXPECT_EQ(segs.size(), static_cast<std::size_t>(f.ny - 1));
    for (const ContourSegment &c : segs) {
        EXPECT_NEAR(c.x0_m, 0.3, 1e-6);
        EXPECT_NEAR(c.x1_m, 0.3, 1e-6);
    }
}

TEST(FieldImage, ThresholdContourOfAGaussianIsItsHalfHeightCircle)
{
    // w = A exp(-r^2 / (2 sigma^2)) crosses A / 2 at r = sigma sqrt(2 ln 2).
    const double sigma = 0.15, radius = sigma * std::sqrt(2 * std::log(2.0));
    FieldMap f{101, 101, 0, 0, 0.01, 0.01, {}};
    for (int j = 0; j < f.ny; ++j)
        for (int i = 0; i < f.nx; ++i) {
            const double x = i * f.dx_m - 0.5, y = j * f.dy_m - 0.5;
            f.value.push_back(static_cast<float>(8e-6 * std::exp(-(x * x + y * y) / (2 * sigma * sigma))));
        }
    FieldStyle s;
    s.threshold = 4e-6;
    const FieldLayout l = field_layout(f, s);
    const Image img = render_field(f, s);
    const double m_per_px = (l.x1_m - l.x0_m) / l.field_w_px;
    std::vector<int> sector(72, 0);
    for (int r = l.field_y_px; r < l.field_y_px + l.field_h_px; ++r)
        for (int k = l.field_x_px; k < l.field_x_px + l.field_w_px; ++k)
            if (whitish(img.at(k, r))) {
                const double x = l.x0_m + (k + 0.5 - l.field_x_px) * m_per_px;
                const double y = l.y1_m - (r + 0.5 - l.field_y_px) * m_per_px;
                EXPECT_NEAR(std::hypot(x - 0.5, y - 0.5), radius, 1.5 * m_per_px);
                ++sector[static_cast<std::size_t>((std::atan2(y - 0.5, x - 0.5) + M_PI) / (2 * M_PI) * 72) % 72];
            }
    for (std::size_t k = 0; k < sector.size(); ++k) // closed all round: every 5 degrees
        EXPECT_GT(sector[k], 0) << "sector " << k;
}

TEST(FieldImage, NanAndThePlateBeyondTheLatticeAreNoData)
{
    FieldMap f = ramp();
    for (int j = 3; j < 8; ++j)
        for (int i = 80; i < 120; ++i)
            f.value[static_cast<std::size_t>(j) * f.nx + i] = NAN;
    FieldStyle s = ramp_style();
    s.plate_x_m = 1.2; // 0.2 m of plate right of the lattice
    s.plate_y_m = 0.5;
    const FieldLayout l = field_layout(f, s);
    const Image img = render_field(f, s);
    EXPECT_EQ(img.at(col(l, 0.5), row(l, 0.25)), field_no_data_color);
    EXPECT_EQ(img.at(col(l, 1.1), row(l, 0.25)), field_no_data_color);
    EXPECT_EQ(img.at(col(l, 0.5), row(l, 0.05)), published[2]); // below the hole: data
    EXPECT_NE(img.at(col(l, 0.2), row(l, 0.25)), field_no_data_color);
}

TEST(FieldImage, MarkersAndActiveAreaSitWhereTheyAre)
{
    const FieldMap f = ramp();
    FieldStyle s = ramp_style();
    s.markers = {{0.2, 0.4, "3", Marker::Kind::exciter}, {0.7, 0.2, "5", Marker::Kind::focus}};
    s.active_area = std::array<double, 4>{0.1, 0.1, 0.9, 0.4};
    const FieldLayout l = field_layout(f, s);
    const Image img = render_field(f, s);
    EXPECT_EQ(img.at(col(l, 0.2), row(l, 0.4)), field_exciter_color);
    EXPECT_TRUE(whitish(img.at(col(l, 0.7), row(l, 0.2)))); // the focus symbol's cross
    // The dashed outline of the area's left edge: light pixels on about half
    // of its rows, and none a few pixels beside it.
    int on = 0, rows = 0;
    for (int r = row(l, 0.35); r < row(l, 0.15); ++r, ++rows) {
        bool hit = false;
        for (int dk = -1; dk <= 1; ++dk)
            hit |= whitish(img.at(col(l, 0.1) + dk, r));
        on += hit;
        EXPECT_FALSE(whitish(img.at(col(l, 0.1) + 6, r)));
    }
    EXPECT_GT(on, rows / 3);
    EXPECT_LT(on, rows);
}

TEST(FieldImage, BadInputIsRefused)
{
    const FieldStyle s = ramp_style();
    auto refused = [&](FieldMap f, FieldStyle st) {
        EXPECT_THROW(render_field(f, st), std::invalid_argument);
        EXPECT_THROW(field_layout(f, st), std::invalid_argument);
    };
    FieldMap f = ramp();
    f.value.pop_back();
    refused(f, s);
    f = ramp();
    f.nx = 0;
    refused(f, s);
    for (double bad : {0.0, -0.01, double(NAN), double(INFINITY)}) {
        f = ramp();
        f.dx_m = bad;
        refused(f, s);
        f = ramp();
        f.dy_m = bad;
        refused(f, s);
    }
    f = ramp();
    f.x0_m = INFINITY;
    refused(f, s);
    FieldStyle st = s;
    st.vmax = 0.0; // = vmin
    refused(ramp(), st);
    st = s;
    st.scale = 0;
    refused(ramp(), st);
    st = s;
    st.threshold = NAN;
    refused(ramp(), st);
    st = s;
    st.width_px = 40;
    refused(ramp(), st);
    st = s;
    st.active_area = std::array<double, 4>{0.5, 0.1, 0.2, 0.4};
    refused(ramp(), st);
    st = s;
    st.markers = {{NAN, 0.1, "x", Marker::Kind::point}};
    refused(ramp(), st);
    EXPECT_THROW(render_field_uris({ramp(), ramp()}, {s, s, s}), std::invalid_argument);
    EXPECT_EQ(render_field_uris({ramp(), ramp()}, {s}).size(), 2u);
    // The message names what is wrong.
    f = ramp();
    f.value.resize(10);
    try {
        render_field(f, s);
        FAIL();
    } catch (const std::invalid_argument &e) {
        EXPECT_NE(std::string(e.what()).find("nx * ny = 2211 but there are 10 values"), std::string::npos) << e.what();
    }
}

namespace {

std::vector<std::uint8_t> unbase64(const std::string &s)
{
    std::vector<std::uint8_t> out;
    std::uint32_t acc = 0;
    int bits = 0;
    for (char ch : s) {
        int v = ch >= 'A' && ch <= 'Z'   ? ch - 'A'
                : ch >= 'a' && ch <= 'z' ? ch - 'a' + 26
                : ch >= '0' && ch <= '9' ? ch - '0' + 52
                : ch == '+'              ? 62
                : ch == '/'              ? 63
                                         : -1;
        if (v < 0)
            continue;
        acc = (acc << 6) | static_cast<std::uint32_t>(v);
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            out.push_back(static_cast<std::uint8_t>(acc >> bits));
        }
    }
    return out;
}

} // namespace

TEST(FieldMovie, OneSelfContainedFramePerInputOnOneColourScale)
{
    // Uniform frames of 1, 2, 3 and 4 units: on one shared scale they show
    // viridis at 1/4, 1/2, 3/4 and 1; each on its own scale all would be yellow.
    std::vector<FieldMap> frames;
    for (int k = 0; k < 4; ++k)
        frames.push_back({21, 21, 0, 0, 0.01, 0.01, std::vector<float>(21 * 21, static_cast<float>(k + 1))});
    FieldStyle s;
    s.title = "|w| <over> time";
    s.scale = 1;
    s.unit = "units";
    s.width_px = 240;
    const std::string html = field_movie_html(frames, {0.0, 1e-3, 2e-3, 3e-3}, s, "movie-1");
    std::string why;
    EXPECT_TRUE(xml_check::well_formed(html, why)) << why;
    EXPECT_EQ(count(html, "<img "), 4u);
    EXPECT_EQ(count(html, "src=\"data:image/png;base64,"), 4u);
    EXPECT_EQ(count(html, "src="), 4u); // nothing loaded from elsewhere
    EXPECT_EQ(count(html, "href"), 0u);
    EXPECT_EQ(count(html, "http"), 0u);
    EXPECT_EQ(count(html, "hidden=\"hidden\""), 3u);
    EXPECT_EQ(count(html, "id=\"movie-1\""), 1u);
    EXPECT_EQ(count(html, "max=\"3\""), 1u);
    EXPECT_EQ(count(html, "&lt;over&gt;"), 4u); // the title in each alt text, escaped
    for (const char *t : {"t = 0 ms", "t = 1 ms", "t = 2 ms", "t = 3 ms"})
        EXPECT_EQ(count(html, std::string("data-t=\"") + t + "\""), 1u) << t;

    FieldStyle shared = s;
    shared.vmax = 4.0;
    const FieldLayout l = field_layout(frames[0], shared);
    std::size_t at = 0;
    for (int k = 0; k < 4; ++k) {
        at = html.find("base64,", at) + 7;
        const std::vector<std::uint8_t> png = unbase64(html.substr(at, html.find('"', at) - at));
        int w = 0, h = 0, n = 0;
        unsigned char *px = stbi_load_from_memory(png.data(), static_cast<int>(png.size()), &w, &h, &n, 3);
        ASSERT_NE(px, nullptr) << stbi_failure_reason();
        EXPECT_EQ(w, l.width_px);
        EXPECT_EQ(h, l.height_px);
        const std::size_t centre =
            (static_cast<std::size_t>(l.field_y_px + l.field_h_px / 2) * w + l.field_x_px + l.field_w_px / 2) * 3;
        EXPECT_EQ((Color{px[centre], px[centre + 1], px[centre + 2]}), published[k + 1]) << "frame " << k;
        stbi_image_free(px);
    }
}

TEST(FieldMovie, BadInputIsRefused)
{
    const FieldMap f{3, 3, 0, 0, 0.1, 0.1, std::vector<float>(9, 1.0f)};
    const FieldStyle s;
    EXPECT_THROW(field_movie_html({}, {}, s, "m"), std::invalid_argument);
    EXPECT_THROW(field_movie_html({f, f}, {0.0}, s, "m"), std::invalid_argument);
    for (const char *id : {"", "1m", "m x", "m\"x", "m<x"})
        EXPECT_THROW(field_movie_html({f}, {0.0}, s, id), std::invalid_argument) << id;
    FieldMap other = f;
    other.dx_m = 0.2;
    EXPECT_THROW(field_movie_html({f, other}, {0.0, 1.0}, s, "m"), std::invalid_argument);
    FieldMap broken = f;
    broken.value.pop_back();
    EXPECT_THROW(field_movie_html({broken}, {0.0}, s, "m"), std::invalid_argument);
    EXPECT_THROW(field_movie_html({f}, {NAN}, s, "m"), std::invalid_argument);
}
