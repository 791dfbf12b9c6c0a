#include "physics/material.h"

#include <cmath>
#include <stdexcept>

namespace calib::physics {

void Material::validate() const
{
    if (!(density_kg_m3 > 0) || !(youngs_pa > 0) || !std::isfinite(density_kg_m3) || !std::isfinite(youngs_pa))
        throw std::invalid_argument("density and Young's modulus must be positive and finite");
    if (!(poisson > -1.0 && poisson < 0.5))
        throw std::invalid_argument("Poisson's ratio must lie in (-1, 0.5)");
}

double Material::shear_modulus_pa() const { return youngs_pa / (2.0 * (1.0 + poisson)); }

double Material::cl_m_s() const
{
    // lambda + 2 mu = E (1 - nu) / ((1 + nu) (1 - 2 nu))
    return std::sqrt(youngs_pa * (1.0 - poisson) / (density_kg_m3 * (1.0 + poisson) * (1.0 - 2.0 * poisson)));
}

double Material::ct_m_s() const { return std::sqrt(shear_modulus_pa() / density_kg_m3); }

double Material::speed_ratio_squared() const { return (1.0 - 2.0 * poisson) / (2.0 * (1.0 - poisson)); }

double Material::bending_stiffness(double thickness_m) const
{
    return youngs_pa * thickness_m * thickness_m * thickness_m / (12.0 * (1.0 - poisson * poisson));
}

double Material::kappa(double thickness_m) const
{
    return std::sqrt(bending_stiffness(thickness_m) / (density_kg_m3 * thickness_m));
}

const std::vector<Material> &builtin_materials()
{
    static const std::vector<Material> table = {
        // Temperature coefficients and loss ranges: docs/robustness.md (sources there).
        {"acrylic", 1200.0, 4.76e9, 0.38, -4e-3, 0.030, 0.050},
        {"glass", 1590.0, 68.9e9, 0.16, -1e-4, 0, 0},
        {"steel", 7850.0, 205e9, 0.28, -4e-4, 0, 0},
    };
    return table;
}

std::optional<Material> find_material(std::string_view name)
{
    for (const Material &m : builtin_materials())
        if (m.name == name)
            return m;
    return std::nullopt;
}

std::string known_material_names()
{
    std::string s;
    for (const Material &m : builtin_materials())
        s += (s.empty() ? "" : ", ") + m.name;
    return s;
}

Material material_from_elastic(double rho, double E, double nu, std::string name)
{
    Material m{std::move(name), rho, E, nu};
    m.validate();
    return m;
}

Material material_from_speeds(double rho, double cl, double ct, std::string name)
{
    if (!(rho > 0) || !(cl > 0) || !(ct > 0) || !std::isfinite(rho) || !std::isfinite(cl) || !std::isfinite(ct))
        throw std::invalid_argument("density and wave speeds must be positive and finite");
    const double r2 = (ct / cl) * (ct / cl);
    if (!(r2 < 0.75)) // nu > -1  <=>  ct/cl < sqrt(3)/2
        throw std::invalid_argument("c_T must be below sqrt(3)/2 c_L for a physical Poisson's ratio");
    const double nu = (1 - 2 * r2) / (2 * (1 - r2));
    const double E = 2 * rho * ct * ct * (1 + nu);
    return material_from_elastic(rho, E, nu, std::move(name));
}

} // namespace calib::physics
