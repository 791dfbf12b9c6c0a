// The plot writer (cairo): lines land where the drawn frame and the axis
// definition put them (centroids of anti-aliased pixels, to a quarter pixel),
// a NaN breaks a line, a power law is straight on log-log axes, the SVG is
// well-formed XML carrying its words as <text> with ids that do not collide
// between plots, the PNG decodes (stb_image, an independent decoder) to the
// asked size, and failures leave no file behind.
#include "report/plot.h"

#include "xml_check.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include <unistd.h>

#include "png_decode.h"

using namespace calib::report;
using xml_check::count;

namespace {

Plot sample_plot()
{
    Plot p;
    p.title = "A <title> & \"quotes\"";
    p.x = {"frequency (Hz)"};
    p.y = {"velocity (m/s)"};
    std::vector<double> x, y1, y2;
    for (int i = 0; i <= 50; ++i) {
        x.push_back(10 + 20 * i);
        y1.push_back(std::sqrt(x.back()));
        y2.push_back(i == 25 ? NAN : 20 + 0.01 * x.back()); // a gap
    }
    p.add({"sqrt", x, y1});
    p.add({"line with gap", x, y2, LineStyle::dashed});
    return p;
}

// One directory per test and process: ctest runs the tests in parallel.
std::filesystem::path temp_dir()
{
    const auto d = std::filesystem::temp_directory_path() /
                   ("test_plot_" + std::string(testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
                    std::to_string(getpid()));
    std::filesystem::create_directories(d);
    return d;
}

// The plot frame as drawn: the first and last rows and columns that are
// mostly the frame's grey. Pixel column c covers [c, c + 1).
struct Frame {
    int c0 = -1, c1 = -1, r0 = -1, r1 = -1;
};

Frame find_frame(const Image &img)
{
    const Color grey{90, 90, 90};
    Frame f;
    for (int y = 0; y < img.height; ++y) {
        int n = 0;
        for (int x = 0; x < img.width; ++x)
            n += img.at(x, y) == grey;
        if (n > img.width / 2) {
            if (f.r0 < 0)
                f.r0 = y;
            f.r1 = y;
        }
    }
    for (int x = 0; x < img.width; ++x) {
        int n = 0;
        for (int y = 0; y < img.height; ++y)
            n += img.at(x, y) == grey;
        if (n > img.height / 2) {
            if (f.c0 < 0)
                f.c0 = x;
            f.c1 = x;
        }
    }
    return f;
}

// Coverage-weighted centroid (pixel centres at +0.5) of the pixels `weight` picks.
double centroid(const Image &img, bool along_x, const std::function<double(Color)> &weight)
{
    double sw = 0, s = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const double w = weight(img.at(x, y));
            if (w > 0) {
                sw += w;
                s += w * ((along_x ? x : y) + 0.5);
            }
        }
    return sw > 0 ? s / sw : NAN;
}

} // namespace

TEST(Plot, LinesLandWhereTheFrameAndAxesPutThem)
{
    // A horizontal line at y = 3 and a vertical one at x = 7 on [0, 10] x
    // [0, 10] (neither on a grid line): the frame edges are x = 0 and 10.
    Plot p;
    p.x.min = 0.0;
    p.x.max = 10.0;
    p.y.min = 0.0;
    p.y.max = 10.0;
    p.legend = LegendPosition::hidden;
    p.add({"", {0, 10}, {3, 3}, LineStyle::solid, Color{0, 200, 0}});
    p.add({"", {7, 7}, {0, 10}, LineStyle::solid, Color{0, 0, 255}});
    const Image img = render_image(p);
    const Frame f = find_frame(img);
    ASSERT_GE(f.c0, 0);
    ASSERT_GT(f.c1 - f.c0, 300);
    ASSERT_GT(f.r1 - f.r0, 200);
    // Frame lines are 1 px wide and centred on the plot area's edges.
    const double left = f.c0 + 0.5, right = f.c1 + 0.5, top = f.r0 + 0.5, bottom = f.r1 + 0.5;
    const double want_y = bottom - 0.3 * (bottom - top), want_x = left + 0.7 * (right - left);
    const double got_y =
        centroid(img, false, [](Color c) { return c.g > c.r + 20 && c.g > c.b + 20 ? (c.g - c.r) / 200.0 : 0; });
    const double got_x =
        centroid(img, true, [](Color c) { return c.b > c.r + 20 && c.b > c.g + 20 ? (c.b - c.r) / 255.0 : 0; });
    EXPECT_NEAR(got_y, want_y, 0.25);
    EXPECT_NEAR(got_x, want_x, 0.25);
}

TEST(Plot, NanBreaksTheLine)
{
    Plot p;
    p.x.min = 0.0;
    p.x.max = 10.0;
    p.y.min = 0.0;
    p.y.max = 10.0;
    p.legend = LegendPosition::hidden;
    std::vector<double> x, y;
    for (int i = 0; i <= 10; ++i) {
        x.push_back(i);
        y.push_back(i == 5 ? NAN : 5.0);
    }
    p.add({"", x, y, LineStyle::solid, Color{255, 0, 0}});
    const Image img = render_image(p);
    const Frame f = find_frame(img);
    auto red_in_column = [&](double xv) {
        const int c = static_cast<int>(f.c0 + 0.5 + xv / 10 * (f.c1 - f.c0));
        for (int r = f.r0 + 2; r < f.r1 - 1; ++r)
            if (img.at(c, r).r > 200 && img.at(c, r).g < 100)
                return true;
        return false;
    };
    EXPECT_TRUE(red_in_column(2));
    EXPECT_TRUE(red_in_column(8));
    EXPECT_FALSE(red_in_column(5)); // between the points at 4 and 6
}

TEST(Plot, PowerLawIsStraightOnLogLogAxes)
{
    // y = x^2 over four decades: the red pixels lie on one straight line in
    // image coordinates, and the line is not flat.
    Plot p;
    p.x = {"x", AxisScale::log};
    p.y = {"y", AxisScale::log};
    p.legend = LegendPosition::hidden;
    std::vector<double> x, y;
    for (int i = 0; i <= 400; ++i) {
        x.push_back(std::pow(10.0, -2 + 4.0 * i / 400));
        y.push_back(x.back() * x.back());
    }
    p.add({"", x, y, LineStyle::solid, Color{255, 0, 0}});
    const Image img = render_image(p);
    double sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
    std::size_t n = 0;
    for (int yy = 0; yy < img.height; ++yy)
        for (int xx = 0; xx < img.width; ++xx) {
            const Color c = img.at(xx, yy);
            if (c.r > 200 && c.g < 80 && c.b < 80) {
                sx += xx;
                sy += yy;
                sxx += double(xx) * xx;
                sxy += double(xx) * yy;
                syy += double(yy) * yy;
                ++n;
            }
        }
    ASSERT_GT(n, 300u);
    const double mx = sx / n, my = sy / n;
    const double vx = sxx / n - mx * mx, vy = syy / n - my * my, cxy = sxy / n - mx * my;
    EXPECT_LT(cxy / std::sqrt(vx * vy), -0.9999); // y grows upwards: negative in image rows
}

TEST(Plot, SvgIsWellFormedAndCarriesItsWords)
{
    const std::string svg = render_svg(sample_plot());
    std::string why;
    EXPECT_TRUE(xml_check::well_formed(svg, why)) << why;
    // Escaped once, in <title> and in the drawn title.
    EXPECT_EQ(count(svg, "A &lt;title&gt; &amp; &quot;quotes&quot;"), 2u);
    for (const char *word :
         {">frequency (Hz)</text>", ">velocity (m/s)</text>", ">sqrt</text>", ">line with gap</text>", ">1000</text>"})
        EXPECT_EQ(count(svg, word), 1u) << word;
    EXPECT_EQ(count(svg, "<symbol"), 0u); // no glyph outlines
}

namespace {

// Every value that follows `open` up to the next character of `stop`.
std::vector<std::string> values_after(const std::string &s, const std::string &open, const char *stop)
{
    std::vector<std::string> out;
    for (std::size_t at = s.find(open); at != std::string::npos; at = s.find(open, at + 1)) {
        const std::size_t from = at + open.size();
        out.push_back(s.substr(from, s.find_first_of(stop, from) - from));
    }
    return out;
}

} // namespace

TEST(Plot, SvgIdsResolveAndDifferBetweenPlots)
{
    Plot clipped = sample_plot();
    clipped.y.max = 25.0; // sqrt(x) leaves the plot area: the SVG needs a clip path
    const std::string a = render_svg(clipped);
    Plot other = clipped;
    other.title = "another";
    const std::string b = render_svg(other);
    const std::vector<std::string> va = values_after(a, " id=\"", "\""), vb = values_after(b, " id=\"", "\"");
    const std::set<std::string> ia(va.begin(), va.end()), ib(vb.begin(), vb.end());
    ASSERT_FALSE(ia.empty());
    EXPECT_EQ(ia.size(), va.size()); // unique within the document
    for (const std::string &id : ia)
        EXPECT_EQ(ib.count(id), 0u) << id;
    std::vector<std::string> refs = values_after(a, "href=\"#", "\"");
    for (const std::string &r : values_after(a, "url(#", ")"))
        refs.push_back(r);
    EXPECT_GT(refs.size(), 0u);
    for (const std::string &r : refs)
        EXPECT_EQ(ia.count(r), 1u) << r;
}

TEST(Plot, PngDecodesToTheAskedSizeWithTheSeriesColours)
{
    Plot p = sample_plot();
    p.width_px = 640;
    p.height_px = 400;
    const std::string path = (temp_dir() / "sample.png").string();
    write_png(p, path);
    int w = 0, h = 0, n = 0;
    unsigned char *data = stbi_load(path.c_str(), &w, &h, &n, 3);
    ASSERT_NE(data, nullptr) << stbi_failure_reason();
    EXPECT_EQ(w, 640);
    EXPECT_EQ(h, 400);
    auto near = [](const unsigned char *px, int r, int g, int b) {
        return std::abs(px[0] - r) <= 6 && std::abs(px[1] - g) <= 6 && std::abs(px[2] - b) <= 6;
    };
    std::size_t blue = 0, orange = 0;
    for (int i = 0; i < w * h; ++i) {
        blue += near(data + 3 * i, 31, 119, 180);
        orange += near(data + 3 * i, 255, 127, 14);
    }
    stbi_image_free(data);
    EXPECT_GT(blue, 400u);   // a 2 px line across ~550 px
    EXPECT_GT(orange, 200u); // dashed: about half of that
    std::filesystem::remove_all(temp_dir());
}

TEST(Plot, TextIsDrawnAndBadTextDoesNotBlankThePlot)
{
    auto dark_rows = [](const Image &img, int y0, int y1) {
        std::size_t n = 0;
        for (int y = y0; y < y1; ++y)
            for (int x = 0; x < img.width; ++x)
                n += img.at(x, y).r < 100 && img.at(x, y).g < 100 && img.at(x, y).b < 100;
        return n;
    };
    Plot p = sample_plot();
    p.legend = LegendPosition::hidden;
    EXPECT_GT(dark_rows(render_image(p), 0, 30), 100u); // the title's glyphs
    p.title.clear();
    EXPECT_EQ(dark_rows(render_image(p), 0, 8), 0u); // above the top tick label
    // Invalid UTF-8 would put cairo in an error state and stop all drawing.
    p.title = "bad \xff\xfe utf-8 \xe2\x82";
    p.x.label = "ok \xc3\xa9";
    const Image img = render_image(p);
    std::size_t blue = 0;
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x)
            blue += img.at(x, y) == Color{31, 119, 180};
    EXPECT_GT(blue, 300u);
    EXPECT_GT(dark_rows(img, 0, 30), 100u);
}

TEST(Plot, ErrorsLeaveNoFile)
{
    const auto dir = temp_dir();
    Plot p = sample_plot();
    EXPECT_THROW(write_plot(p, (dir / "x.gif").string()), std::invalid_argument);
    EXPECT_FALSE(std::filesystem::exists(dir / "x.gif"));
    EXPECT_THROW(write_plot(p, (dir / "no-such-dir" / "x.png").string()), std::runtime_error);
    EXPECT_THROW(write_plot(p, (dir / "no-such-dir" / "x.svg").string()), std::runtime_error);
    EXPECT_FALSE(std::filesystem::exists(dir / "no-such-dir"));
    Plot bad = p;
    bad.series[0].y.pop_back();
    EXPECT_THROW(render_svg(bad), std::invalid_argument);
    EXPECT_THROW(write_plot(bad, (dir / "bad.png").string()), std::invalid_argument);
    EXPECT_TRUE(std::filesystem::is_empty(dir));
    Plot empty;
    EXPECT_THROW(render_image(empty), std::invalid_argument);
    Plot logneg = p;
    logneg.y.scale = AxisScale::log;
    logneg.y.min = -1.0;
    EXPECT_THROW(render_svg(logneg), std::invalid_argument);
    // Upper-case extension works.
    write_plot(p, (dir / "UPPER.SVG").string());
    EXPECT_TRUE(std::filesystem::exists(dir / "UPPER.SVG"));
    std::filesystem::remove_all(dir);
}
