// format.h - one number into text through a printf format, for messages and
// reports ("%.3g", "%.1f MB"): the format takes exactly one double.
#pragma once

#include <cstdio>
#include <string>

namespace calib::io {

inline std::string fmt(const char *format, double v)
{
    char b[64];
    std::snprintf(b, sizeof b, format, v);
    return b;
}

}  // namespace calib::io
