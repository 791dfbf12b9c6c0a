// Images of a scalar field over the plate (|w| at an instant, a contrast map):
// a perceptually uniform colour map (viridis) with a colour bar and ticks in
// a display unit, the perception threshold marked on the bar and drawn as a
// contour on the field, exciters and foci as markers, the plate and the active
// area outlined. And a self-contained HTML movie of such images over time.
//
//   report::FieldMap m{nx, ny, 0, 0, h, h, values};   // metres, NaN = no data
//   report::FieldStyle s;
//   s.title = "|w| at the focus instant";
//   s.threshold = 5e-6;                                // drawn on the bar and as a contour
//   s.markers.push_back({0.35, 0.35, "4", report::Marker::Kind::focus});
//   std::string uri = report::png_data_uri(report::render_field(m, s));
#pragma once
#include "report/image.h"

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace calib::report {

struct FieldMap {              // samples of a scalar field on a regular lattice
    int nx = 0, ny = 0;        // samples along x and y
    double x0_m = 0, y0_m = 0; // position of sample (0, 0)
    double dx_m = 0, dy_m = 0; // spacing
    std::vector<float> value;  // row-major (j, i), j along y (y up on the image); NaN = no data
};

struct Marker {
    double x_m = 0, y_m = 0;
    std::string label;
    enum class Kind { focus, exciter, point } kind = Kind::point;
};

struct FieldStyle {
    std::string title;
    std::string unit = "um";          // unit shown on the colour bar
    double scale = 1e6;               // value * scale is shown in `unit`
    std::optional<double> vmin, vmax; // in field units (m); unset: 0 .. max
    std::optional<double> threshold;  // in field units; marked on the colour bar and drawn as a contour
    std::vector<Marker> markers;
    double plate_x_m = 0, plate_y_m = 0; // plate outline [0, plate_x_m] x [0, plate_y_m] (0 = the lattice's extent)
    std::optional<std::array<double, 4>> active_area; // x0, y0, x1, y1: outlined
    int width_px = 720;
};

// Colours a reader (and a test) can rely on.
inline constexpr Color field_no_data_color{200, 200, 200}; // NaN samples, plate outside the lattice
inline constexpr Color field_contour_color{255, 255, 255}; // the threshold contour (on a dark halo)
inline constexpr Color field_exciter_color{214, 39, 40};

// Where render_field puts things: the field area in pixels and the map from
// plate coordinates to pixel coordinates (x right, y down on the image).
struct FieldLayout {
    int width_px = 0, height_px = 0;
    int field_x_px = 0, field_y_px = 0, field_w_px = 0, field_h_px = 0; // top-left corner and size
    double x0_m = 0, y0_m = 0, x1_m = 0, y1_m = 0;                      // the extent shown
    int bar_x_px = 0, bar_y_px = 0, bar_w_px = 0, bar_h_px = 0;         // the colour bar
    double vmin = 0, vmax = 0;                                          // colour scale, field units

    double px_x(double x_m) const { return field_x_px + (x_m - x0_m) / (x1_m - x0_m) * field_w_px; }
    double px_y(double y_m) const { return field_y_px + (y1_m - y_m) / (y1_m - y0_m) * field_h_px; }
};

// Both throw std::invalid_argument (one line naming the field) for a lattice
// without samples, nx * ny != value.size(), a non-positive or non-finite
// spacing, a non-finite origin, vmax <= vmin, a non-positive scale, a
// non-finite threshold or marker, a negative plate size, an empty active area
// or a width outside 160..8000 px.
FieldLayout field_layout(const FieldMap &field, const FieldStyle &style);
Image render_field(const FieldMap &field, const FieldStyle &style); // with colour bar and ticks in `unit`

// PNG data URIs of several field images, rendered on all cores (OpenMP): one
// style for all, or one per field. Throws as render_field, or
// std::invalid_argument if the number of styles is neither 1 nor fields.size().
std::vector<std::string> render_field_uris(const std::vector<FieldMap> &fields, const std::vector<FieldStyle> &styles);

// A self-contained HTML fragment (no external files, no network): the frames as PNG data URIs with a
// slider and a play button (a few lines of inline JS), sharing one colour scale, a time label per frame.
// Throws std::invalid_argument for no frames, frames.size() != times_s.size(), frames on different
// lattices, or an element_id that is not a letter followed by letters, digits, '-' or '_'.
std::string field_movie_html(const std::vector<FieldMap> &frames, const std::vector<double> &times_s,
                             const FieldStyle &style, const std::string &element_id);

} // namespace calib::report
