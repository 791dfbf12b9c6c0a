// What an ideal focus of the pulse scores on the whole-area criterion: the
// field of a perfect, isotropic refocusing on an infinite lossless plate
// (waves arriving from every direction alike, nothing reverberating after),
//
//   w(r, t) = Re sum_f S(f) J0(k(f) r) e^{i 2 pi f t},
//
// with k(f) the plate's A0 wavenumber and S the pulse's spectrum (a drive that
// puts exactly the pulse at the focus: the inverse filter's aim) or its power
// spectrum (time reversal: the pulse's autocorrelation at the focus). Its
// focal peak over its largest |w| at radii beyond `radius_m` (lambda/2 in the
// verification) and all times is the diffraction limit of the criterion: the
// first sidelobe ring, near 0.6 lambda, which a monochromatic focus has at
// 0.403 of the peak (J0's first extremum, -7.9 dB) and a short pulse lower,
// its rings of different frequencies falling at different radii. It is the
// reference an exciter layout and a drive design are measured against, not a
// proven bound for every design (a non-isotropic focus trades its rings
// between directions).
#pragma once
#include "pipeline/pulse.h"

#include <functional>

namespace calib::pipeline {

struct FocusCeiling {
    double target_db = 0;            // S = the pulse's spectrum
    double autocorrelation_db = 0;   // S = its power spectrum (time reversal)
    double target_ring_radius_m = 0; // where the target's largest |w| beyond radius_m is
};

// wavenumber_per_m(f_hz): the A0 wavenumber at f.
FocusCeiling ideal_focus_ceiling(const PulseSpec &pulse, const std::function<double(double)> &wavenumber_per_m,
                                 double radius_m);

}  // namespace calib::pipeline
