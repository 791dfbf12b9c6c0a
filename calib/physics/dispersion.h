// Guided waves in an isotropic elastic plate: the exact Rayleigh-Lamb modes
// (symmetric S_n, antisymmetric A_n), the shear-horizontal modes SH_n, and the
// Kirchhoff and Mindlin flexural approximations of A0 that the plate engine
// and the accuracy studies compare against.
//
// Everything here is computed from the material's E, nu and rho, as the FD
// engine is: the exact modes through the bulk speeds c_L, c_T derived from
// them, the plate theories directly. So exact A0 and Kirchhoff meet in the
// low-frequency limit for every material. See docs/dispersion.md.
#pragma once
#include "physics/material.h"

#include <string>
#include <string_view>
#include <vector>

namespace calib::physics {

enum class ModeFamily { antisymmetric, symmetric, shear_horizontal };

struct ModePoint {
    ModeFamily family = ModeFamily::antisymmetric;
    int order = 0; // n in A_n / S_n / SH_n, counted at this frequency
    double f_hz = 0;
    double wavenumber_rad_m = 0;   // k
    double phase_velocity_m_s = 0; // omega / k
    double group_velocity_m_s = 0; // d omega / d k (negative on backward-wave branches)
    double wavelength_m = 0;       // 2 pi / k

    std::string name() const; // "A0", "S1", "SH2", ...
};

// All propagating modes (real k > 0) at frequency f, sorted by family
// (A, S, SH) and then by order. Within the A and S families the order is the
// rank by decreasing k (increasing phase velocity) at this frequency: between
// a zero-group-velocity point and its cut-off a backward-wave branch takes the
// next index. Throws std::invalid_argument for f <= 0, thickness <= 0 or a
// material that fails Material::validate().
std::vector<ModePoint> solve_modes(const Material &m, double thickness_m, double f_hz);

// One family only (cheaper): used by the single-mode helpers below.
std::vector<ModePoint> solve_family(const Material &m, double thickness_m, double f_hz, ModeFamily family);

// The fundamental modes. Each exists at every f > 0.
ModePoint a0_mode(const Material &m, double thickness_m, double f_hz);
ModePoint s0_mode(const Material &m, double thickness_m, double f_hz);
double a0_phase_velocity(const Material &m, double thickness_m, double f_hz);
double a0_group_velocity(const Material &m, double thickness_m, double f_hz);
double a0_wavelength(const Material &m, double thickness_m, double f_hz);

// Kirchhoff-Love plate: c = sqrt(omega kappa), c_g = 2 c, lambda = c / f =
// 2 pi sqrt(kappa / omega). The plate constant kappa (m^2/s,
// Material::kappa) alone decides them: the _m_s and _m forms take it as a
// plate operator or a material gives it, and are the one place these
// formulas are written; the material forms check their inputs first.
double kirchhoff_phase_velocity_m_s(double kappa_m2_s, double f_hz);
double kirchhoff_group_velocity_m_s(double kappa_m2_s, double f_hz);
double kirchhoff_wavelength_m(double kappa_m2_s, double f_hz);
double kirchhoff_phase_velocity(const Material &m, double thickness_m, double f_hz);
double kirchhoff_group_velocity(const Material &m, double thickness_m, double f_hz);

// Mindlin-Reissner plate (shear deformation and rotary inertia), flexural
// branch. The shear correction factor k^2 is either Mindlin's pi^2/12 (its
// thickness-shear cut-off then equals the exact A1 cut-off c_T/(2d)) or
// (c_R/c_T)^2 (its high-frequency limit then equals the exact A0 limit, the
// Rayleigh speed).
enum class MindlinShear { pi2_over_12, rayleigh };
double mindlin_shear_factor(const Material &m, MindlinShear choice);
double mindlin_phase_velocity(const Material &m, double thickness_m, double f_hz,
                              MindlinShear choice = MindlinShear::pi2_over_12);
double mindlin_group_velocity(const Material &m, double thickness_m, double f_hz,
                              MindlinShear choice = MindlinShear::pi2_over_12);

// Bulk and limit speeds of the plate's material.
double rayleigh_speed(const Material &m); // surface wave: the A0 and S0 limit at high f*d
double plate_speed(const Material &m);    // sqrt(E / (rho (1 - nu^2))): S0 at low f*d

// Analytic cut-off frequencies (k = 0) of the family's higher modes up to
// f_max, ascending: A: (2n+1) c_T/(2d) and 2n c_L/(2d); S: 2n c_T/(2d) and
// (2n+1) c_L/(2d); SH: n c_T/(2d) (n >= 1).
std::vector<double> cutoff_frequencies(const Material &m, double thickness_m, ModeFamily family, double f_max_hz);

namespace detail {
// The scaled Rayleigh-Lamb characteristic function of a family (A or S) at
// x = (k h)^2, W2 = (omega h / c_T)^2, r = (c_T / c_L)^2, and its partial
// derivatives; exposed for tests (see dispersion.cpp for the forms).
struct CharValue {
    double F, dF_dx, dF_dW2;
};
enum class CharForm { automatic, series, direct };
CharValue lamb_characteristic(ModeFamily family, double x, double W2, double r, CharForm form = CharForm::automatic);
} // namespace detail

} // namespace calib::physics
