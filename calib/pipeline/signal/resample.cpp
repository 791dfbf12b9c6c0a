#include "pipeline/signal/resample.h"

#include <soxr.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::pipeline {

std::vector<double> resample(const std::vector<double> &x, double in_rate, double out_rate)
{
    return std::move(resample_all({x}, in_rate, out_rate)[0]);
}

std::vector<std::vector<double>> resample_all(const std::vector<std::vector<double>> &x, double in_rate,
                                              double out_rate)
{
    if (x.empty())
        return {};
    const std::size_t len = x[0].size();
    for (const std::vector<double> &c : x)
        if (c.size() != len)
            throw std::invalid_argument("resample: signals differ in length");
    if (len == 0 || in_rate == out_rate)
        return x;
    const auto out_len = static_cast<size_t>(std::llround(static_cast<double>(len) * out_rate / in_rate));
    std::vector<std::vector<double>> y(x.size(), std::vector<double>(out_len));
    // One filter design for every channel of a group: soxr runs them one after
    // another through the same filter ("split" channels, one buffer each).
    // Groups of resample_group_channels: soxr allocates the buffers of every
    // channel of a call at once, so a group's are few enough to come back from
    // the heap's free lists, still in cache, for the next group (all 464 sites
    // of a Fig. 7 emitter in one call faulted tens of MB in afresh each time).
    // Each channel's output is the same bytes in any grouping.
    const soxr_io_spec_t io = soxr_io_spec(SOXR_FLOAT64_S, SOXR_FLOAT64_S);
    const soxr_quality_spec_t q = soxr_quality_spec(SOXR_HQ | SOXR_LINEAR_PHASE, 0);
    const soxr_runtime_spec_t rt = soxr_runtime_spec(1);
    std::size_t done = out_len;
    for (std::size_t c0 = 0; c0 < x.size(); c0 += resample_group_channels) {
        const std::size_t n = std::min(resample_group_channels, x.size() - c0);
        std::vector<const double *> in(n);
        std::vector<double *> out(n);
        for (std::size_t c = 0; c < n; c++) {
            in[c] = x[c0 + c].data();
            out[c] = y[c0 + c].data();
        }
        std::size_t group_done = 0;
        const soxr_error_t err = soxr_oneshot(in_rate, out_rate, unsigned(n), in.data(), len, nullptr, out.data(),
                                              out_len, &group_done, &io, &q, &rt);
        if (err)
            throw std::runtime_error(std::string("soxr: ") + err);
        done = std::min(done, group_done);
    }
    for (std::vector<double> &c : y)
        c.resize(done);
    return y;
}

} // namespace calib::pipeline
