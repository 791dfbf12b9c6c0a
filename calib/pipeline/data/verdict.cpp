#include "pipeline/data/verdict.h"

#include "io/format.h"

#include <algorithm>
#include <cmath>

namespace calib::pipeline {

std::string FocusMetrics::failure(double threshold_m) const
{
    std::string why;
    auto add = [&](const std::string &part) { why += (why.empty() ? "" : "; ") + part; };
    if (!crosses_threshold)
        add(io::fmt("peak %.2f um below the %.2f um threshold", peak_m * 1e6, threshold_m * 1e6));
    if (whole_area && !whole_area_below_threshold)
        add(io::fmt("ghost %.2f um at (%.1f, %.1f) mm, %+.1f dB over the threshold", max_whole_area_m * 1e6,
                    whole_area_max_at.x_m * 1e3, whole_area_max_at.y_m * 1e3, ratio_db(max_whole_area_m, threshold_m)));
    if (!others_below_threshold)
        add(io::fmt("another focus reaches %.2f um, %+.1f dB over the threshold", max_other_foci_m * 1e6,
                    ratio_db(max_other_foci_m, threshold_m)));
    return why;
}

haptic_gain_range FocusMetrics::gain_range(double threshold_m) const
{
    // What passes() judges beyond lambda/2: the other foci, and the whole
    // area where it was measured (the same terms, the same scope).
    const double elsewhere = std::max(max_other_foci_m, whole_area ? max_whole_area_m : 0.0);
    haptic_gain_range r{threshold_m / peak_m, elsewhere > 0 ? threshold_m / elsewhere : INFINITY};
    // At g = 1 these are the verification's own comparisons (peak >= threshold,
    // elsewhere < threshold), exactly: a correctly rounded quotient of doubles
    // is <= 1 exactly when the dividend is <= the divisor (for a > b the
    // quotient exceeds 1 by more than half an ulp of 1), so
    // passes() == (lo <= 1 && 1 < hi) bit for bit.
    if (!(r.lo <= HAPTIC_TABLE_RANGE_MAX_GAIN))
        return {HAPTIC_TABLE_RANGE_MAX_GAIN, HAPTIC_TABLE_RANGE_MAX_GAIN};
    if (r.hi > HAPTIC_TABLE_RANGE_MAX_GAIN)
        r.hi = INFINITY;
    return r;
}

std::string safe_range_text(const haptic_gain_range &r)
{
    if (!any_gain_passes(r))
        return "none";
    return io::fmt("%+.1f .. ", gain_db(r.lo)) +
           (std::isinf(r.hi) ? std::string("unbounded") : io::fmt("%+.1f", gain_db(r.hi)));
}

VerdictSummary summarize_verdict(const std::vector<FocusMetrics> &foci)
{
    VerdictSummary s;
    s.total = foci.size();
    for (std::size_t f = 0; f < foci.size(); f++) {
        s.passing += foci[f].passes();
        if (foci[f].margin_db() < foci[s.worst].margin_db())
            s.worst = f;
    }
    s.worst_margin_db = foci.empty() ? 0.0 : foci[s.worst].margin_db();
    return s;
}

} // namespace calib::pipeline
