// Small line-plot writer for reports: linear or log axes, legend, title, to
// SVG (vector, for docs and inline in HTML reports) or PNG, both drawn by
// cairo (anti-aliased, real fonts through its toy text API). Used by
// `calibgen dispersion --plot`, the accuracy study and the calibration report.
//
//   report::Plot p;
//   p.title = "A0 phase velocity, 2 mm";
//   p.x = {"frequency (Hz)", report::AxisScale::log};
//   p.y = {"phase velocity (m/s)"};
//   p.add({"acrylic", f, c});
//   p.add({"Kirchhoff", f, ck, report::LineStyle::dashed});
//   report::write_plot(p, "out.svg");   // or .png
#pragma once
#include "report/image.h"

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace calib::report {

enum class AxisScale { linear, log };
enum class LineStyle { solid, dashed, dotted, none }; // none: markers only
enum class LegendPosition { top_right, top_left, bottom_right, bottom_left, hidden };

// The i-th colour of the default palette (Tableau 10), cycling.
Color palette(std::size_t i);

struct Axis {
    Axis() = default;
    Axis(std::string label_, AxisScale scale_ = AxisScale::linear) : label(std::move(label_)), scale(scale_) {}

    std::string label;
    AxisScale scale = AxisScale::linear;
    std::optional<double> min, max; // unset: fit the data (log: positive data only)
};

struct Series {
    Series() = default;
    Series(std::string label_, std::vector<double> x_, std::vector<double> y_, LineStyle style_ = LineStyle::solid,
           std::optional<Color> color_ = std::nullopt)
        : label(std::move(label_)), x(std::move(x_)), y(std::move(y_)), style(style_), color(color_)
    {}

    std::string label;        // empty: not in the legend
    std::vector<double> x, y; // same length; a NaN (or <= 0 on a log axis) breaks the line
    LineStyle style = LineStyle::solid;
    std::optional<Color> color; // unset: palette(index of the series)
    bool markers = false;       // a dot at every point
    double width_px = 2.0;
};

struct Plot {
    std::string title;
    Axis x, y;
    std::vector<Series> series;
    LegendPosition legend = LegendPosition::top_right;
    int width_px = 800, height_px = 560;

    Plot &add(Series s)
    {
        series.push_back(std::move(s));
        return *this;
    }
};

// All throw std::invalid_argument for an unusable plot (series x/y length
// mismatch, no finite data on an axis, non-positive size, log axis with
// min <= 0) and std::runtime_error for I/O failures. The writers go through a
// temporary file and rename, so a failure leaves no partial file. The SVG
// carries the title, axis labels and series names in <title> and <desc>
// (cairo writes the visible text as glyph outlines) and ids unique to its
// content, so several plots can be inlined in one HTML page.
std::string render_svg(const Plot &plot);
Image render_image(const Plot &plot);
void write_svg(const Plot &plot, const std::string &path);
// encode_png (PNG file bytes of an Image) is in report/image.h.
void write_png(const Plot &plot, const std::string &path);
// By extension: .svg or .png (case-insensitive); anything else is
// std::invalid_argument naming the path.
void write_plot(const Plot &plot, const std::string &path);

} // namespace calib::report
