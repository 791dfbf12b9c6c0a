#include "engine/effects/finger.h"

#include <stdexcept>
#include <string>

namespace calib::engine::effects {

template <typename T>
FingerExtension<T>::FingerExtension(const PlateEngine<T> &engine, const FingerSpec &spec)
    : spec_(spec), k_(engine.time_step())
{
    if (!(spec.mass_kg >= 0) || !(spec.stiffness_n_m >= 0) || !(spec.damping_n_s_m >= 0))
        throw std::invalid_argument("finger: mass, stiffness and damping must be >= 0");
    for (const auto &nw : engine.plate().point_weights(spec.x_m, spec.y_m)) {
        if (taps_ == offset_.size())
            break;
        offset_[taps_] = engine.field_offset(nw.node);
        weight_[taps_] = nw.weight;
        gain_[taps_] = nw.weight * engine.force_gain(nw.node);
        g_ += nw.weight * gain_[taps_];
        ++taps_;
    }
    if (taps_ == 0)
        throw std::invalid_argument("finger: the point lies on held nodes only");
    // The spring is explicit: it adds s phi phi^T to K, which raises
    // lambda_max(M^-1 K) by at most s g / k^2. It must fit in the margin the
    // time step leaves below the plate's bound, k^2/4 lambda <= 1.
    const double lambda = engine.plate().lambda_max_stiffness();
    const double margin = 1.0 - k_ * k_ * lambda / 4.0;
    if (spec.stiffness_n_m * g_ / 4.0 >= margin)
        throw std::invalid_argument("finger: stiffness_n_m too high for the time step (needs s < " +
                                    std::to_string(4.0 * margin / g_) + " N/m)");
}

template <typename T>
void FingerExtension<T>::after_update(PlateEngine<T> &engine)
{
    T *next = engine.newest_field();
    const T *cur = engine.field_before();
    const T *prev = engine.field_two_before();
    double wp = 0, w = 0, wm = 0;
    for (std::size_t n = 0; n < taps_; ++n) {
        wp += weight_[n] * double(next[offset_[n]]);
        w += weight_[n] * double(cur[offset_[n]]);
        wm += weight_[n] * double(prev[offset_[n]]);
    }
    const double m = spec_.mass_kg, c = spec_.damping_n_s_m, s = spec_.stiffness_n_m, k = k_;
    // f = beta - alpha W+, W+ = W+free + g f.
    const double alpha = m / (k * k) + c / (2 * k);
    const double beta = m * (2 * w - wm) / (k * k) + c * wm / (2 * k) - s * w;
    const double w_new = (wp + g_ * beta) / (1 + g_ * alpha);
    force_ = beta - alpha * w_new;
    for (std::size_t n = 0; n < taps_; ++n)
        next[offset_[n]] += T(gain_[n] * force_);
    const double v = (w_new - w) / k;
    energy_ = 0.5 * m * v * v + 0.5 * s * w_new * w;
}

template class FingerExtension<float>;
template class FingerExtension<double>;

}  // namespace calib::engine::effects
