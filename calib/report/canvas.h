// The few things every report figure needs from cairo: a surface to draw on
// (an RGB raster or an SVG document), colours, and text placed by anchor.
// Text uses cairo's toy font API with the family "sans-serif" (fontconfig
// picks DejaVu Sans on Debian), which needs no pango.
#pragma once
#include "report/image.h"

#include <cairo.h>

#include <functional>
#include <string>
#include <string_view>

namespace calib::report::canvas {

enum class Anchor { start, middle, end };

using DrawFn = std::function<void(cairo_t *)>;

// Runs `draw` on a white w x h canvas. Throws std::runtime_error if cairo
// reports an error; exceptions of `draw` pass on with the surface freed.
Image paint_image(int width_px, int height_px, const DrawFn &draw);
// The same drawing as an SVG document (cairo's SVG surface), `title` as its
// <title>. Text goes in as SVG <text> elements in the family "DejaVu Sans,
// sans-serif" rather than cairo's glyph outlines (as matplotlib's
// svg.fonttype = "none"): the words stay searchable and selectable, and an
// inlined plot does not carry ~50 kB of glyph shapes. Element ids carry a
// prefix derived from the content, so several of these SVGs can be inlined
// in one HTML page.
std::string paint_svg(int width_px, int height_px, const DrawFn &draw, const std::string &title);

void set_color(cairo_t *cr, Color c, double alpha = 1.0);
// Text with its anchor at (x, y), y being the middle of the line (capital
// height); vertical text reads bottom to top. Invalid UTF-8 and control
// characters are replaced by '?', which cairo would otherwise refuse by
// putting the whole context into an error state.
void text(cairo_t *cr, double x, double y, std::string_view s, double size_px, Anchor a, bool vertical = false);
// Light text with a dark outline: readable on any colour of a field image.
void text_halo(cairo_t *cr, double x, double y, std::string_view s, double size_px, Anchor a);
double text_width(cairo_t *cr, std::string_view s, double size_px);

std::string valid_utf8(std::string_view s);
std::string xml_escape(std::string_view s);

} // namespace calib::report::canvas
