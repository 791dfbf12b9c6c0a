#include "pipeline/signal/resample.h"

#include <soxr.h>

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
    std::vector<const double *> in(x.size());
    std::vector<double *> out(x.size());
    for (std::size_t c = 0; c < x.size(); c++) {
        in[c] = x[c].data();
        out[c] = y[c].data();
    }
    size_t done = 0;
    // One filter design for every channel: soxr runs them one after another
    // through the same filter ("split" channels, one buffer each).
    const soxr_io_spec_t io = soxr_io_spec(SOXR_FLOAT64_S, SOXR_FLOAT64_S);
    const soxr_quality_spec_t q = soxr_quality_spec(SOXR_HQ | SOXR_LINEAR_PHASE, 0);
    const soxr_runtime_spec_t rt = soxr_runtime_spec(1);
    soxr_error_t err = soxr_oneshot(in_rate, out_rate, unsigned(x.size()), in.data(), len, nullptr, out.data(), out_len,
                                    &done, &io, &q, &rt);
    if (err)
        throw std::runtime_error(std::string("soxr: ") + err);
    for (std::vector<double> &c : y)
        c.resize(done);
    return y;
}

} // namespace calib::pipeline
