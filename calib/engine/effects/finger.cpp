#include "engine/effects/finger.h"

#include <stdexcept>
#include <string>

namespace calib::engine::effects {

FingerExtension::FingerExtension(const PointField &engine, const FingerSpec &spec)
    : spec_(spec), k_(engine.time_step()), point_(engine.couple(spec.x_m, spec.y_m, "finger"))
{
    if (!(spec.mass_kg >= 0) || !(spec.stiffness_n_m >= 0) || !(spec.damping_n_s_m >= 0))
        throw std::invalid_argument("finger: mass, stiffness and damping must be >= 0");
    // The spring is explicit: it adds s phi phi^T to K, which raises
    // lambda_max(M^-1 K) by at most s g / k^2. It must fit in the margin the
    // time step leaves below the plate's bound, k^2/4 lambda <= 1.
    const double lambda = engine.lambda_max();
    const double margin = 1.0 - k_ * k_ * lambda / 4.0;
    if (spec.stiffness_n_m * point_.g / 4.0 >= margin)
        throw std::invalid_argument("finger: stiffness_n_m too high for the time step (needs s < " +
                                    std::to_string(4.0 * margin / point_.g) + " N/m)");
}

void FingerExtension::after_update(PointField &engine)
{
    const auto [wp, w, wm] = engine.read(point_);
    const double m = spec_.mass_kg, c = spec_.damping_n_s_m, s = spec_.stiffness_n_m, k = k_;
    // f = beta - alpha W+, W+ = W+free + g f.
    const double alpha = m / (k * k) + c / (2 * k);
    const double beta = m * (2 * w - wm) / (k * k) + c * wm / (2 * k) - s * w;
    const double w_new = (wp + point_.g * beta) / (1 + point_.g * alpha);
    force_ = beta - alpha * w_new;
    engine.apply(point_, force_);
    const double v = (w_new - w) / k;
    energy_ = 0.5 * m * v * v + 0.5 * s * w_new * w;
}

} // namespace calib::engine::effects
