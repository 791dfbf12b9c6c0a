// format.h - numbers into text through a printf format, for messages and
// reports ("%g", "%.3g", "%.1f MB", "T60 %.3g s at %.4g Hz"): the one place
// calibgen turns a number into text by a format, whatever the length.
#pragma once

#include <cstddef>
#include <cstdio>
#include <string>

namespace calib::io {

template <typename Value, typename... More>
std::string fmt(const char *format, Value value, More... more)
{
    char b[128];
    const int n = std::snprintf(b, sizeof b, format, value, more...);
    if (n < 0)
        return {};
    if (static_cast<std::size_t>(n) < sizeof b)
        return std::string(b, static_cast<std::size_t>(n));
    std::string s(static_cast<std::size_t>(n) + 1, '\0');
    std::snprintf(s.data(), s.size(), format, value, more...);
    s.resize(static_cast<std::size_t>(n));
    return s;
}

} // namespace calib::io
