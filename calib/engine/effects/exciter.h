// The exciter effect: an inertial electrodynamic exciter as a force source
// with its own resonance, coupled to the plate at one point (PointExtension),
// and the inverse filter that pre-compensates drive signals for it.
//
// State: the magnet's displacement z (moving mass M on suspension k, c). With
// W the plate displacement at the point (bilinear weights, as a receiver) and
// i the coil current during the step,
//   M z_tt = -k (z - W) - c (z_t - W_t) - Bl i,   F_plate = -M z_tt
// (momentum is conserved: the plate gets the reaction of the magnet). Centred
// in time, F depends on W+ = W+free + g F, solved exactly per step as for the
// finger. Into a blocked plate F / (Bl i) = M s^2 / (M s^2 + c s + k); on a
// moving plate F = T(s) Bl i - Zm(s) W with Zm = M s^2 (c s + k) / (M s^2 + c s + k).
#pragma once

#include "engine/effects/effects.h"
#include "engine/point_field.h"

#include <complex>
#include <cstddef>
#include <vector>

namespace calib::engine::effects {

// Blocked-force transfer T(j 2 pi f) = F / (Bl i), dimensionless.
std::complex<double> exciter_transfer(const ExciterSpec &e, double f_hz);
double exciter_resonance_hz(const ExciterSpec &e);
double exciter_q(const ExciterSpec &e); // infinite without damping
// Throws std::invalid_argument naming the parameter if one is not usable.
void check_exciter(const ExciterSpec &e);

class ExciterExtension final : public PointExtension {
  public:
    ExciterExtension(const PointField &engine, double x_m, double y_m, const ExciterSpec &spec);
    // current_a[n] is the coil current during the n-th step after this call.
    void set_drive(std::vector<double> current_a);
    void after_update(PointField &engine) override;

    // Force on the plate in every step since set_drive (N).
    const std::vector<double> &forces() const { return forces_; }

  private:
    ExciterSpec spec_;
    double k_ = 0;
    PointTaps point_;
    double z_ = 0, z_prev_ = 0;
    std::vector<double> drive_;
    std::size_t n_ = 0;
    std::vector<double> forces_;
};

// Filters `signal` (sampled at rate_hz) by the regularised inverse of the
// exciter's blocked transfer, C = conj(T) / (|T|^2 + eps^2) with eps set so
// that |C| <= max_boost: exactly 1/T where the exciter is efficient (in the
// band above its resonance), capped below it, where 1/T grows as 1/f^2. The
// result is what Bl i must be so that the delivered force is the input.
// Zero-padded FFT (no wrap-around): output has the input's length.
std::vector<double> precompensate(const std::vector<double> &signal, double rate_hz, const ExciterSpec &e);

// The force the exciter delivers into a blocked plate for a drive Bl i
// (sampled at rate_hz): the input filtered by T (zero-padded FFT). This is the
// exciter in calibrate's forward simulation (the plate's loading of the
// exciter is left out there; ExciterExtension models it, see docs/effects.md).
std::vector<double> blocked_force(const std::vector<double> &bl_i, double rate_hz, const ExciterSpec &e);

// Relative loading of the exciter by the plate at f: |Zm / (j omega)| times the
// infinite-plate point mobility 1 / (8 sqrt(D rho d)): what the blocked-force
// approximation leaves out.
double exciter_plate_loading(const ExciterSpec &e, double bending_stiffness, double mass_per_area, double f_hz);

} // namespace calib::engine::effects
