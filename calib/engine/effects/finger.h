// The finger effect: a point mass-spring-damper on the plate, applied as a
// sparse hook after the bulk and edge update (EngineExtension).
//
// With W = phi^T u the displacement at the point (bilinear weights phi, the
// same as a receiver), the force on the plate at step n is
//   f^n = -( m (W+ - 2 W + W-) / k^2 + c (W+ - W-) / (2 k) + s W )
// (mass and damper centred, spring at level n: the leapfrog of the plate's own
// stiffness). f depends on W+, which depends on f: W+ = W+free + g f with
// g = sum phi^2 (displacement per newton of this step), so the coupled scalar
// equation is solved exactly (one division) and f is spread back with the
// source weights. The mass joins M as a rank-one term (Sherman-Morrison), the
// scheme stays explicit and energy-consistent; cost: ~20 flops per step.
#pragma once

#include "engine/effects/effects.h"
#include "engine/effects/point_coupling.h"
#include "engine/plate_engine.h"

#include <array>
#include <cstddef>

namespace calib::engine::effects {

template <typename T>
class FingerExtension final : public EngineExtension<T> {
public:
    // Throws std::invalid_argument if the point is off the plate or on fixed nodes only.
    FingerExtension(const PlateEngine<T> &engine, const FingerSpec &spec);
    void after_update(PlateEngine<T> &engine) override;

    double last_force_n() const { return force_; }  // force on the plate in the last step (N)
    // Energy stored in the finger (J) at n+1/2: 1/2 m W_t^2 + 1/2 s W+ W.
    double energy() const { return energy_; }

private:
    FingerSpec spec_;
    double k_ = 0;
    PointCoupling<T> point_;
    double force_ = 0, energy_ = 0;
};

extern template class FingerExtension<float>;
extern template class FingerExtension<double>;

}  // namespace calib::engine::effects
