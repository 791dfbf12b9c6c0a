// Isotropic elastic materials: the built-in library is the seed's Table I.
#pragma once
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace calib::physics {

struct Material {
    std::string name;
    double density_kg_m3 = 0;   // rho
    double youngs_pa = 0;       // E
    double poisson = 0;         // nu
    double cl_m_s = 0;          // longitudinal (bulk) wave speed
    double ct_m_s = 0;          // transverse (shear) wave speed

    // Bending stiffness D = E d^3 / (12 (1 - nu^2)) for thickness d (m).
    double bending_stiffness(double thickness_m) const;
    // kappa = sqrt(D / (rho d)) (m^2/s), the Kirchhoff plate constant.
    double kappa(double thickness_m) const;
};

// Seed Table I: acrylic, glass, steel (values as printed in the paper; c_L
// and c_T are the paper's and not recomputed from E and nu).
const std::vector<Material> &builtin_materials();
std::optional<Material> find_material(std::string_view name);
// "acrylic, glass, steel"
std::string known_material_names();

// Custom materials. from_elastic derives c_L, c_T from E, nu, rho; from_speeds
// derives E, nu from c_L, c_T, rho. Both throw std::invalid_argument on
// non-physical input (nu outside (-1, 0.5), c_T >= c_L / sqrt(2), ...).
Material material_from_elastic(double density_kg_m3, double youngs_pa, double poisson, std::string name = "custom");
Material material_from_speeds(double density_kg_m3, double cl_m_s, double ct_m_s, std::string name = "custom");

}  // namespace calib::physics
