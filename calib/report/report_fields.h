// The field figures of the calibration report (calibration_report.cpp):
// the whole-area contrast of every focus as a map over the active area, |w|
// at the focus instants, and the worst focus over all times (image and
// movie). Up to a dozen foci every figure is drawn for every focus; a dense
// grid gets the map, and per-focus figures for three foci only.
#pragma once
#include "report/calibration_report.h"

#include <cstddef>
#include <string>
#include <vector>

namespace calib::report {

constexpr std::size_t max_foci_drawn = 12;
bool few_foci(const ReportContext &c);

// The foci whose field and traces are drawn: all of a few (and every focus of
// a device drive); of a dense grid the worst, the median and the best by
// whole-area contrast (by contrast over the other foci when the whole area
// was not measured).
std::vector<std::size_t> shown_foci(const ReportContext &c);

// The sections "Whole-area contrast over the active area", "Wave field at the
// focus instant" (the shown foci) and "Whole area: the worst focus".
std::string field_sections_html(const ReportContext &c, const std::vector<std::size_t> &shown);

// A number for the page, `prec` significant digits.
std::string num(double v, int prec = 3);

} // namespace calib::report
