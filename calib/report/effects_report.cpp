#include "report/effects_report.h"

#include "engine/effects/exciter.h"
#include "io/format.h"
#include "physics/dispersion.h"

#include <cmath>
#include <numbers>

namespace calib::report {

using engine::PlateParams;
using namespace engine::effects;

using io::fmt;

double kirchhoff_phase_error(const physics::Material &m, double thickness_m, double f_hz)
{
    const double exact = physics::a0_phase_velocity(m, thickness_m, f_hz);
    return std::abs(physics::kirchhoff_phase_velocity(m, thickness_m, f_hz) - exact) / exact;
}

std::vector<EffectStatus> assess_effects(const EffectsSpec &spec, const PlateParams &plate, double f_lo_hz,
                                         double f_hi_hz, const EffectSupport &support)
{
    std::vector<EffectStatus> out;
    const double d = plate.thickness_m;
    const physics::Material &mat = plate.material;
    const double kappa = mat.kappa(d);

    // Loss: the T60 of the plate's decay rate sigma(omega).
    {
        EffectStatus s{"loss", plate.loss.active(), false, 0, ""};
        if (s.active) {
            auto t60 = [&](double f) {
                return engine::t60_of_decay_rate_s(plate.loss.decay_rate_1_s(2 * std::numbers::pi * f, kappa));
            };
            s.why = fmt("on ([plate.loss]): T60 %.3g s at %.4g Hz", t60(f_hi_hz), f_hi_hz) +
                    fmt(", %.3g s at %.4g Hz", t60(f_lo_hz), f_lo_hz);
        } else {
            s.why = spec.loss && !*spec.loss ? "off (effects.loss = false): T60 assumed infinite (lossless plate)"
                                             : "off (no [plate.loss]): T60 assumed infinite (lossless plate)";
        }
        out.push_back(s);
    }
    // Thick plate: the Kirchhoff phase error at the top of the band, and the
    // phase it accumulates across the plate's diagonal.
    {
        const double e = kirchhoff_phase_error(mat, d, f_hi_hz);
        const double diag = std::hypot(plate.size_x_m, plate.size_y_m);
        const double cycles = diag / physics::a0_wavelength(mat, d, f_hi_hz);
        EffectStatus s{"thick_plate", spec.thick_plate, e < negligible_relative, e, ""};
        const std::string est = fmt("Kirchhoff A0 phase-velocity error %.2g %% at f_max = %.4g Hz (f*d = %.3g kHz mm)",
                                    100 * e, f_hi_hz, f_hi_hz * d) +
                                fmt(", %.0f deg of phase over the plate diagonal", 360 * e * cycles);
        if (spec.thick_plate && !support.thick_plate) {
            s.active = false;
            s.why = "asked, but NOT composed (the caller's simulation runs the Kirchhoff engine only): " + est;
        } else if (spec.thick_plate)
            s.why =
                std::string(s.negligible ? "on (asked; negligible here)" : "on (asked)") +
                " (Mindlin engine in every simulation: calibration and verification); left out it would cost: " + est;
        else
            s.why =
                std::string(s.negligible ? "off (negligible): " : "off (NOT negligible, set effects.thick_plate): ") +
                est;
        out.push_back(s);
    }
    // Finger: its mass against the plate mass under one wavelength squared at f_max.
    {
        const double lambda = physics::a0_wavelength(mat, d, f_hi_hz);
        const double local = mat.density_kg_m3 * d * lambda * lambda;
        EffectStatus s{"finger", spec.finger.has_value(), false, 0, ""};
        if (spec.finger) {
            const double ratio = spec.finger->mass_kg / local;
            s.estimated_error = ratio;
            s.negligible = ratio < negligible_relative;
            s.active = support.finger;
            s.why = std::string(
                        support.finger
                            ? "on (asked; composed in the verification (playback) runs only, not in the calibration)"
                            : "asked, but NOT composed (no extension hook in this simulation)") +
                    fmt(" at (%.3g, %.3g) m: ", spec.finger->x_m, spec.finger->y_m) +
                    fmt("finger mass / plate mass under lambda^2 at f_max = %.2g", ratio) +
                    (s.negligible ? " (negligible)" : "");
        } else {
            const double typical = 0.005; // a fingertip's effective mass, ~5 g
            s.estimated_error = typical / local;
            s.negligible = s.estimated_error < negligible_relative;
            s.why = fmt("off (no [effects.finger]): a 5 g fingertip would be %.2g of the plate mass under lambda^2 at "
                        "f_max (%.3g kg)",
                        s.estimated_error, local);
        }
        out.push_back(s);
    }
    // Exciter: the blocked-force transfer across the band.
    {
        EffectStatus s{"exciter", spec.exciter.has_value(), false, 0, ""};
        if (spec.exciter) {
            const ExciterSpec &e = *spec.exciter;
            const double lo = std::abs(exciter_transfer(e, f_lo_hz)), hi = std::abs(exciter_transfer(e, f_hi_hz));
            s.estimated_error = std::max(std::abs(1 - lo), std::abs(1 - hi));
            s.negligible = s.estimated_error < negligible_relative;
            s.why = fmt("on (asked): resonance %.4g Hz, Q %.3g", exciter_resonance_hz(e), exciter_q(e)) +
                    fmt(", |F / Bl i| = %.2f at %.4g Hz", lo, f_lo_hz) + fmt(", %.2f at %.4g Hz", hi, f_hi_hz) +
                    (e.precompensate ? "; drive signals pre-compensated" : "; no pre-compensation") +
                    fmt("; plate loading left out: %.2g",
                        std::max(exciter_plate_loading(e, mat.bending_stiffness(d), mat.density_kg_m3 * d, f_lo_hz),
                                 exciter_plate_loading(e, mat.bending_stiffness(d), mat.density_kg_m3 * d, f_hi_hz)));
        } else {
            s.why = "off (no [effects.exciter]): exciters are ideal force sources";
        }
        out.push_back(s);
    }
    return out;
}

std::vector<std::string> describe_effects(const std::vector<EffectStatus> &status)
{
    std::vector<std::string> out;
    for (const EffectStatus &s : status)
        out.push_back("effect " + s.name + ": " + s.why);
    return out;
}

} // namespace calib::report
