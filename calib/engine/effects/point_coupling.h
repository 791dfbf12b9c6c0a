// A point of the plate as a sparse hook (finger, exciter) sees it: the
// receiver's bilinear weights phi read W = phi^T u at the three time levels,
// the source's gains spread a force back, and g = sum phi * gain is the
// displacement per newton of one step at the point (what makes the coupled
// scalar equation of each hook solvable exactly).
#pragma once

#include "engine/plate_engine.h"

#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace calib::engine::effects {

template <typename T>
class PointCoupling {
public:
    // Throws std::invalid_argument (naming `effect`) off the plate or on held nodes only.
    PointCoupling(const PlateEngine<T> &engine, double x_m, double y_m, const char *effect)
    {
        for (const auto &nw : engine.plate().point_weights(x_m, y_m)) {
            if (taps_ == offset_.size())
                break;
            offset_[taps_] = engine.field_offset(nw.node);
            weight_[taps_] = nw.weight;
            gain_[taps_] = nw.weight * engine.force_gain(nw.node);
            g_ += nw.weight * gain_[taps_];
            ++taps_;
        }
        if (taps_ == 0)
            throw std::invalid_argument(std::string(effect) + ": the point lies on held nodes only");
    }

    // W at step n+1 (before this hook's force), n and n-1: the engine keeps
    // u^{n+1} and the increments d^{n+1}, d^n, so W^n = W^{n+1} - phi^T d^{n+1}.
    struct Levels {
        double next = 0, now = 0, prev = 0;
    };
    Levels read(const PlateEngine<T> &engine) const
    {
        const T *u = engine.newest_field(), *d1 = engine.newest_increment(), *d0 = engine.increment_before();
        double w = 0, step1 = 0, step0 = 0;
        for (std::size_t n = 0; n < taps_; ++n) {
            w += weight_[n] * double(u[offset_[n]]);
            step1 += weight_[n] * double(d1[offset_[n]]);
            step0 += weight_[n] * double(d0[offset_[n]]);
        }
        return {w, w - step1, w - step1 - step0};
    }
    // Adds the displacement a force (N) applied during this step causes.
    void apply(PlateEngine<T> &engine, double force_n) const
    {
        for (std::size_t n = 0; n < taps_; ++n)
            engine.add_displacement(offset_[n], T(gain_[n] * force_n));
    }
    double g() const { return g_; }

private:
    std::size_t taps_ = 0;
    std::array<std::ptrdiff_t, 4> offset_{};
    std::array<double, 4> weight_{};  // interpolation weight phi
    std::array<double, 4> gain_{};    // phi * force gain: displacement per newton
    double g_ = 0;
};

}  // namespace calib::engine::effects
