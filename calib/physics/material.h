// Isotropic elastic materials. A material is defined by E, nu and rho alone;
// every derived constant (c_L, c_T, the shear modulus, the plate constants)
// is computed from those three, so the exact Rayleigh-Lamb modes, the plate
// theories and the FD engine always describe the same solid.
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace calib::physics {

struct Material {
    std::string name;
    double density_kg_m3 = 0; // rho
    double youngs_pa = 0;     // E
    double poisson = 0;       // nu
    // What varies between panels and with the room (docs/robustness.md):
    // relative change of E per kelvin near room temperature (dE/E/dT, 1/K),
    // and the stated range of the loss factor eta in the audio band (0, 0:
    // none stated). Not used by the plate itself; the tolerance study reads them.
    double youngs_per_kelvin = 0;
    double loss_factor_min = 0, loss_factor_max = 0;

    // Throws std::invalid_argument unless rho, E are positive and finite and
    // nu lies in (-1, 0.5) (the range where the solid is stable).
    void validate() const;

    double shear_modulus_pa() const; // mu = E / (2 (1 + nu))
    // Longitudinal (bulk) speed c_L = sqrt(E (1 - nu) / (rho (1 + nu) (1 - 2 nu))).
    double cl_m_s() const;
    // Transverse (shear) speed c_T = sqrt(mu / rho).
    double ct_m_s() const;
    // (c_T / c_L)^2 = (1 - 2 nu) / (2 (1 - nu)), computed from nu directly.
    double speed_ratio_squared() const;

    // Bending stiffness D = E d^3 / (12 (1 - nu^2)) for thickness d (m).
    double bending_stiffness(double thickness_m) const;
    // kappa = sqrt(D / (rho d)) (m^2/s), the Kirchhoff plate constant.
    double kappa(double thickness_m) const;
};

// Seed Table I: acrylic, glass, steel, by the E, nu and rho the paper prints.
// (Its printed c_L, c_T are not used: they are rounded and, for acrylic, 1 %
// off the E and nu printed beside them; see docs/dispersion.md.)
const std::vector<Material> &builtin_materials();
std::optional<Material> find_material(std::string_view name);
// "acrylic, glass, steel"
std::string known_material_names();

// Custom materials. from_elastic takes E, nu, rho as they are; from_speeds
// derives E, nu from c_L, c_T, rho (the speeds computed back from the result
// equal the given ones to rounding). Both throw std::invalid_argument on
// non-physical input (nu outside (-1, 0.5), c_T >= sqrt(3)/2 c_L, ...).
Material material_from_elastic(double density_kg_m3, double youngs_pa, double poisson, std::string name = "custom");
Material material_from_speeds(double density_kg_m3, double cl_m_s, double ct_m_s, std::string name = "custom");

} // namespace calib::physics
