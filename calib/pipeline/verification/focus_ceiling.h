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
// its rings of different frequencies falling at different radii.
//
// It bounds every field that puts the pulse itself at the focus, on the
// radii whose circle around the focus lies in the judged area and a few
// wavelengths from the plate's edges and the exciters. There, at each
// frequency, the field is sum_n a_n J_n(k r) e^{i n theta} (the evanescent
// I_n terms of the edges have decayed); only J0 is non-zero at r = 0, so the
// focal waveform fixes a_0 = S, and the mean of w over the circle is the
// ideal focus's w(r, t). |w| somewhere on the circle is at least that mean:
// no exciter layout or drive design scores above this figure at such a focus
// (tests/calib/test_focus_ceiling.cpp checks fields with random J_1..J_4
// content). A focus closer to the area's edge than its ring can leave part
// of the ring outside the judged area, and a focus of another waveform (more
// high-frequency content) has another figure.
#pragma once
#include "pipeline/signal/pulse.h"

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

} // namespace calib::pipeline
