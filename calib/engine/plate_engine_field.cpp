// The field of a PlateEngine as others see it: one point for the effect
// extensions (point_field.h), and the scan for non-finite values of
// Simulation::run.
#include "engine/non_finite.h"
#include "engine/plate_engine.h"
#include "io/format.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace calib::engine {

template <typename T>
PointTaps PlateEngine<T>::couple(double x_m, double y_m, const char *effect) const
{
    PointTaps p;
    for (const auto &nw : op_->point_weights(x_m, y_m)) {
        if (p.count == p.index.size())
            break;
        p.index[p.count] = offset_of(nw.node);
        p.weight[p.count] = nw.weight;
        p.gain[p.count] = nw.weight * force_gain(nw.node);
        p.g += nw.weight * p.gain[p.count];
        ++p.count;
    }
    if (p.count == 0)
        throw std::invalid_argument(std::string(effect) + ": the point lies on held nodes only");
    return p;
}

// The engine keeps u^{n+1} and the increments d^{n+1}, d^n, so
// W^n = W^{n+1} - phi^T d^{n+1} and W^{n-1} = W^n - phi^T d^n.
template <typename T>
PointLevels PlateEngine<T>::read(const PointTaps &point) const
{
    double w = 0, step1 = 0, step0 = 0;
    for (std::size_t n = 0; n < point.count; ++n) {
        const std::ptrdiff_t o = point.index[n];
        w += point.weight[n] * double(u_[o]);
        step1 += point.weight[n] * double(inc_[o]);
        step0 += point.weight[n] * double(inc_before_[o]);
    }
    return {w, w - step1, w - step1 - step0};
}

template <typename T>
void PlateEngine<T>::apply(const PointTaps &point, double force_n)
{
    for (std::size_t n = 0; n < point.count; ++n)
        add_displacement(point.index[n], T(point.gain[n] * force_n));
}

template <typename T>
std::string PlateEngine<T>::non_finite_report() const
{
    if (scanned_clean_ == steps_)
        return {};
    bool bad = false;
    if (bulk_threads_ > 1) {
        // Each thread scans the rows its sweep updates (block_seam): a scan
        // on one thread pulls the other's rows into its cache, and the
        // other's next sweep then waits for them (docs/engine.md, "Speed").
#pragma omp parallel num_threads(bulk_threads_) reduction(|| : bad)
        {
            const int t = omp_get_thread_num(), n = omp_get_num_threads();
            const int a = t == 0 ? 0 : block_seam(1, ny_, n, t),
                      b = t + 1 == n ? ny_ + 1 : block_seam(1, ny_, n, t + 1);
            for (int j = a; j < b && !bad; ++j)
                bad = any_non_finite(u_ + j * stride_, nx_ + 1);
        }
    } else {
        for (int j = 0; j <= ny_ && !bad; ++j)
            bad = any_non_finite(u_ + j * stride_, nx_ + 1);
    }
    if (!bad)
        return {};
    int fi = -1, fj = -1, i0 = nx_, i1 = 0, j0 = ny_, j1 = 0;
    std::size_t count = 0;
    double first = 0;
    for (int j = 0; j <= ny_; ++j)
        for (int i = 0; i <= nx_; ++i) {
            const double v = double(u_[j * stride_ + i]);
            if (std::isfinite(v))
                continue;
            if (count++ == 0) {
                fi = i;
                fj = j;
                first = v;
            }
            i0 = std::min(i0, i), i1 = std::max(i1, i), j0 = std::min(j0, j), j1 = std::max(j1, j);
        }
    const double h = op_->grid().h;
    using io::fmt;
    return "non-finite displacement (" + fmt("%g", first) + ") at step " + std::to_string(steps_ - 1) +
           " (t = " + fmt("%.6g", double(steps_) * k_) + " s), first at node (i, j) = (" + std::to_string(fi) + ", " +
           std::to_string(fj) + "), (x, y) = (" + fmt("%.6g", fi * h) + ", " + fmt("%.6g", fj * h) + ") m; " +
           std::to_string(count) + " non-finite nodes in i " + std::to_string(i0) + ".." + std::to_string(i1) + ", j " +
           std::to_string(j0) + ".." + std::to_string(j1);
}

#define PLATE_ENGINE_FIELD(T)                                                                                          \
    template PointTaps PlateEngine<T>::couple(double, double, const char *) const;                                     \
    template PointLevels PlateEngine<T>::read(const PointTaps &) const;                                                \
    template void PlateEngine<T>::apply(const PointTaps &, double);                                                    \
    template std::string PlateEngine<T>::non_finite_report() const;
PLATE_ENGINE_FIELD(float)
PLATE_ENGINE_FIELD(double)
#undef PLATE_ENGINE_FIELD

} // namespace calib::engine
