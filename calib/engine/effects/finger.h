// The finger effect: a point mass-spring-damper on the plate, applied as a
// sparse hook after the engine's update (PointExtension), on the Kirchhoff
// and the Mindlin engine alike.
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
#include "engine/point_field.h"

namespace calib::engine::effects {

class FingerExtension final : public PointExtension {
  public:
    // Throws std::invalid_argument if the point is off the plate or on fixed
    // nodes only, or for a spring the time step cannot take.
    FingerExtension(const PointField &engine, const FingerSpec &spec);
    void after_update(PointField &engine) override;

    double last_force_n() const { return force_; } // force on the plate in the last step (N)
    // Energy stored in the finger (J) at n+1/2: 1/2 m W_t^2 + 1/2 s W+ W.
    double energy() const { return energy_; }

  private:
    FingerSpec spec_;
    double k_ = 0;
    PointTaps point_;
    double force_ = 0, energy_ = 0;
};

} // namespace calib::engine::effects
