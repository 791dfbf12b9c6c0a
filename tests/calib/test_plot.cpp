// The plot writer: SVG is well-formed XML with the plot's text escaped, PNG
// decodes (stb_image) to the asked size, lines land where the axis transform
// puts them (a power law is straight on log-log axes), and failures leave no
// file behind.
#include "report/plot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-field-initializers"
#pragma GCC diagnostic ignored "-Wsign-compare"
#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>
#pragma GCC diagnostic pop

using namespace calib::report;

namespace {

// Minimal XML well-formedness: balanced and properly nested elements, quoted
// attributes, only the five predefined entities, one root element.
bool well_formed(const std::string &s, std::string &why)
{
    std::vector<std::string> stack;
    std::size_t i = 0, roots = 0;
    auto entity_ok = [&](std::size_t at) {
        for (const char *e : {"&amp;", "&lt;", "&gt;", "&quot;", "&apos;"})
            if (s.compare(at, std::strlen(e), e) == 0)
                return true;
        return false;
    };
    while (i < s.size()) {
        if (s[i] == '&') {
            if (!entity_ok(i))
                return why = "bad entity at " + std::to_string(i), false;
            ++i;
            continue;
        }
        if (s[i] != '<') {
            if (s[i] == '>')
                return why = "stray > at " + std::to_string(i), false;
            ++i;
            continue;
        }
        if (s.compare(i, 5, "<?xml") == 0) {
            i = s.find("?>", i);
            if (i == std::string::npos)
                return why = "unterminated prolog", false;
            i += 2;
            continue;
        }
        const std::size_t end = s.find('>', i);
        if (end == std::string::npos)
            return why = "unterminated tag", false;
        std::string tag = s.substr(i + 1, end - i - 1);
        i = end + 1;
        if (!tag.empty() && tag[0] == '/') {
            if (stack.empty() || stack.back() != tag.substr(1))
                return why = "mismatched </" + tag.substr(1) + ">", false;
            stack.pop_back();
            continue;
        }
        const bool self_closing = !tag.empty() && tag.back() == '/';
        if (self_closing)
            tag.pop_back();
        const std::string name = tag.substr(0, tag.find_first_of(" \t\n"));
        if (name.empty())
            return why = "empty tag name", false;
        // Attributes: name="value" pairs, values without '<'.
        std::size_t p = name.size();
        while (p < tag.size()) {
            while (p < tag.size() && std::isspace(static_cast<unsigned char>(tag[p])))
                ++p;
            if (p >= tag.size())
                break;
            const std::size_t eq = tag.find('=', p);
            if (eq == std::string::npos || eq + 1 >= tag.size() || tag[eq + 1] != '"')
                return why = "unquoted attribute in <" + name + ">", false;
            const std::size_t close = tag.find('"', eq + 2);
            if (close == std::string::npos)
                return why = "unterminated attribute in <" + name + ">", false;
            if (tag.substr(eq + 2, close - eq - 2).find('<') != std::string::npos)
                return why = "< in attribute", false;
            p = close + 1;
        }
        if (stack.empty())
            ++roots;
        if (!self_closing)
            stack.push_back(name);
    }
    if (!stack.empty())
        return why = "unclosed <" + stack.back() + ">", false;
    if (roots != 1)
        return why = "expected one root element", false;
    return true;
}

std::size_t count(const std::string &s, const std::string &needle)
{
    std::size_t n = 0;
    for (std::size_t at = s.find(needle); at != std::string::npos; at = s.find(needle, at + 1))
        ++n;
    return n;
}

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
        y2.push_back(i == 25 ? NAN : 20 + 0.01 * x.back());  // a gap
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

}  // namespace

TEST(Plot, SvgIsWellFormedAndEscapesText)
{
    const std::string svg = render_svg(sample_plot());
    std::string why;
    EXPECT_TRUE(well_formed(svg, why)) << why;
    EXPECT_NE(svg.find("A &lt;title&gt; &amp; &quot;quotes&quot;"), std::string::npos);
    EXPECT_NE(svg.find("frequency (Hz)"), std::string::npos);
    EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);
    // The NaN splits the dashed series in two polylines: 3 data polylines +
    // 2 legend samples (plus grid and frame lines, which are grey).
    EXPECT_EQ(count(svg, "stroke=\"#1f77b4\""), 2u);  // palette(0): data + legend
    EXPECT_EQ(count(svg, "stroke=\"#ff7f0e\""), 3u);  // palette(1): two runs + legend
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
    std::size_t non_white = 0, blue = 0, orange = 0;
    for (int i = 0; i < w * h; ++i) {
        const unsigned char *px = data + 3 * i;
        non_white += !(px[0] == 255 && px[1] == 255 && px[2] == 255);
        blue += px[0] == 31 && px[1] == 119 && px[2] == 180;
        orange += px[0] == 255 && px[1] == 127 && px[2] == 14;
    }
    stbi_image_free(data);
    EXPECT_GT(non_white, 5000u);
    EXPECT_GT(blue, 400u);    // a 2 px line across ~560 px
    EXPECT_GT(orange, 200u);  // dashed: about half of that
    std::filesystem::remove_all(temp_dir());
}

TEST(Plot, PowerLawIsStraightOnLogLogAxes)
{
    // y = x^2 over four decades: every fully covered red pixel lies on one
    // straight line in image coordinates, and the line is not flat.
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
            const std::uint8_t *px = &img.rgb[(static_cast<std::size_t>(yy) * img.width + xx) * 3];
            if (px[0] == 255 && px[1] == 0 && px[2] == 0) {
                sx += xx; sy += yy; sxx += double(xx) * xx; sxy += double(xx) * yy; syy += double(yy) * yy;
                ++n;
            }
        }
    ASSERT_GT(n, 300u);
    const double mx = sx / n, my = sy / n;
    const double vx = sxx / n - mx * mx, vy = syy / n - my * my, cxy = sxy / n - mx * my;
    const double corr = cxy / std::sqrt(vx * vy);
    EXPECT_LT(corr, -0.9999);  // y grows upwards: negative in image rows
}

TEST(Plot, LinearAxisPutsAConstantOnOneRow)
{
    Plot p;
    p.y.min = 0.0;
    p.y.max = 10.0;
    p.legend = LegendPosition::hidden;
    p.add({"", {0, 1}, {5, 5}, LineStyle::solid, Color{0, 200, 0}});
    const Image img = render_image(p);
    int row_min = img.height, row_max = -1;
    for (int yy = 0; yy < img.height; ++yy)
        for (int xx = 0; xx < img.width; ++xx) {
            const std::uint8_t *px = &img.rgb[(static_cast<std::size_t>(yy) * img.width + xx) * 3];
            if (px[0] == 0 && px[1] == 200 && px[2] == 0) {
                row_min = std::min(row_min, yy);
                row_max = std::max(row_max, yy);
            }
        }
    ASSERT_GE(row_max, 0);
    EXPECT_LE(row_max - row_min, 2);
    // y = 5 of [0, 10] is the middle of the plot area, which sits between the
    // title-less top margin and the tick labels: well inside the image middle third.
    EXPECT_GT(row_min, img.height / 3);
    EXPECT_LT(row_max, 2 * img.height / 3);
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
