#include "pipeline/data/verdict.h"

#include "io/format.h"

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

}  // namespace calib::pipeline
