#include "report/ticks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>

namespace calib::report {

namespace {

std::string tick_label(double v, double step)
{
    char buf[32];
    if (v == 0)
        return "0";
    const double a = std::abs(v);
    if (a >= 1e6 || a < 1e-3) {
        std::snprintf(buf, sizeof buf, "%.3g", v);
        std::string o = buf; // 2.5e+06 -> 2.5e6
        for (const char *from : {"e+0", "e+", "e-0"}) {
            const std::size_t at = o.find(from);
            if (at != std::string::npos) {
                o.replace(at, std::strlen(from), from[1] == '-' ? "e-" : "e");
                break;
            }
        }
        return o;
    }
    const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
    std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
    return buf;
}

std::string decade_label(int e)
{
    if (e >= -3 && e <= 4) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%g", std::pow(10.0, e));
        return buf;
    }
    return "1e" + std::to_string(e);
}

Ticks log_ticks(const Axis &axis, double dmin, double dmax, const char *which)
{
    if ((axis.min && !(*axis.min > 0)) || (axis.max && !(*axis.max > 0)))
        throw std::invalid_argument(std::string(which) + " axis: log scale needs positive min and max");
    Ticks t;
    double lo = axis.min.value_or(dmin), hi = axis.max.value_or(dmax);
    if (!(hi > lo)) {
        lo /= 10;
        hi *= 10;
    }
    const int e0 = static_cast<int>(std::floor(std::log10(lo) + 1e-9));
    int e1 = static_cast<int>(std::ceil(std::log10(hi) - 1e-9));
    if (e1 <= e0)
        e1 = e0 + 1;
    t.lo = axis.min ? lo : std::pow(10.0, e0);
    t.hi = axis.max ? hi : std::pow(10.0, e1);
    const int every = std::max(1, (e1 - e0 + 7) / 8);
    for (int e = e0; e <= e1; ++e) {
        const double d = std::pow(10.0, e);
        if (d >= t.lo * (1 - 1e-9) && d <= t.hi * (1 + 1e-9) && (e - e0) % every == 0) {
            t.major.push_back(d);
            t.labels.push_back(decade_label(e));
        }
        if (every == 1)
            for (int k = 2; k <= 9; ++k)
                if (k * d > t.lo && k * d < t.hi)
                    t.minor.push_back(k * d);
    }
    return t;
}

} // namespace

Ticks make_ticks(const Axis &axis, double dmin, double dmax, const char *which)
{
    if (axis.scale == AxisScale::log)
        return log_ticks(axis, dmin, dmax, which);
    Ticks t;
    double lo = axis.min.value_or(dmin), hi = axis.max.value_or(dmax);
    if (!std::isfinite(lo) || !std::isfinite(hi))
        throw std::invalid_argument(std::string(which) + " axis: range is not finite");
    if (!(hi > lo)) {
        const double pad = lo == 0 ? 1 : 0.1 * std::abs(lo);
        lo -= pad;
        hi += pad;
    }
    const double raw = (hi - lo) / 6;
    const double p10 = std::pow(10.0, std::floor(std::log10(raw)));
    double step = p10;
    for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
        if (m * p10 >= raw) {
            step = m * p10;
            break;
        }
    t.lo = axis.min ? lo : std::floor(lo / step + 1e-9) * step;
    t.hi = axis.max ? hi : std::ceil(hi / step - 1e-9) * step;
    const long first = std::lround(std::ceil(t.lo / step - 1e-9)), last = std::lround(std::floor(t.hi / step + 1e-9));
    for (long k = first; k <= last; ++k) {
        const double v = static_cast<double>(k) * step; // no accumulated round-off
        t.major.push_back(k == 0 ? 0.0 : v);
        t.labels.push_back(tick_label(k == 0 ? 0.0 : v, step));
    }
    return t;
}

} // namespace calib::report
